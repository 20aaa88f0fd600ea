// ops_reduce.h — differentiable reductions. dims may be negative; an empty dims list reduces every dim;
// keepdim keeps reduced dims as size 1 (same contract as tensor/ops.h).
//
// Gradients: sum broadcasts g back; mean also divides by the number of reduced elements; amax/amin send the
// gradient to the extreme elements and SPLIT it evenly between ties (each of k tied elements gets g/k);
// max(a, dim) sends it to the FIRST maximum only (the returned index); logsumexp gives g * softmax(a).
// Errors: dims out of range, duplicate dims (from the tensor ops), amax/amin/max over an empty axis.
#pragma once
#include <vector>

#include "autograd/variable.h"

namespace t2m::ag {

Variable sum(const Variable& a, const std::vector<int64_t>& dims = {}, bool keepdim = false);
Variable mean(const Variable& a, const std::vector<int64_t>& dims = {}, bool keepdim = false);
Variable amax(const Variable& a, const std::vector<int64_t>& dims = {}, bool keepdim = false);
Variable amin(const Variable& a, const std::vector<int64_t>& dims = {}, bool keepdim = false);
Variable logsumexp(const Variable& a, int64_t dim, bool keepdim = false);

// Sums a (broadcast) tensor back to `shape` (the reverse of broadcasting); da = expand(g, A).
Variable sum_to(const Variable& a, const Shape& shape);

// max along one dim: differentiable values and the int64 argmax indices (first maximum wins).
struct MaxResult {
  Variable values;
  Tensor indices;
};
MaxResult max(const Variable& a, int64_t dim, bool keepdim = false);
// Not differentiable.
Tensor argmax(const Variable& a, int64_t dim, bool keepdim = false);

// The shape `a_shape` reduced over `dims` with keepdim = true (reduced dims become 1). Shared with nn/.
Shape reduced_shape_keepdim(const Shape& a_shape, const std::vector<int64_t>& dims, const char* op);

}  // namespace t2m::ag
