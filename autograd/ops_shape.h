// ops_shape.h — differentiable views and layout changes. Forward results share storage with the input (like the
// Tensor views in tensor/tensor.h; reshape copies when no view is possible; contiguous copies when needed).
//
// Gradients: reshape/view/flatten/squeeze/unsqueeze reshape g back to A; transpose/permute apply the inverse
// permutation; slice/select/narrow scatter g into zeros of shape A; expand sums g back to A; contiguous passes
// g through. Errors: the same as the Tensor methods (bad dims, incompatible shapes, out-of-range indices).
#pragma once
#include <vector>

#include "autograd/variable.h"

namespace t2m::ag {

Variable view(const Variable& a, const Shape& shape);
Variable reshape(const Variable& a, const Shape& shape);
Variable transpose(const Variable& a, int64_t d0, int64_t d1);
Variable permute(const Variable& a, const std::vector<int64_t>& dims);
Variable slice(const Variable& a, int64_t dim, int64_t start, int64_t end, int64_t step = 1);
Variable select(const Variable& a, int64_t dim, int64_t index);
Variable narrow(const Variable& a, int64_t dim, int64_t start, int64_t length);
Variable expand(const Variable& a, const Shape& shape);
Variable squeeze(const Variable& a, int64_t dim);
Variable unsqueeze(const Variable& a, int64_t dim);
Variable flatten(const Variable& a, int64_t start_dim = 0, int64_t end_dim = -1);
Variable contiguous(const Variable& a);

}  // namespace t2m::ag
