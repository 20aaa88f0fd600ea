// ops_join.h — differentiable joins and splits.
//
// concat(ts, dim): inputs agree except along dim; out has the summed size there; each input gets its slice of g.
// stack(ts, dim): inputs of one shape S; out inserts a new dim of size ts.size() at dim; input i gets g.select(dim, i).
// split(a, sizes, dim) / chunk(a, chunks, dim): views of a (sizes as in tensor/ops.h; chunk sizes are
// ceil(n / chunks) with a smaller last one); each piece is a narrow of a, so gradients of all pieces add up in a.
// Errors: empty list, mismatched shapes/dtypes, sizes not summing to the dim (from the tensor ops).
#pragma once
#include <vector>

#include "autograd/variable.h"

namespace t2m::ag {

Variable concat(const std::vector<Variable>& ts, int64_t dim);
Variable stack(const std::vector<Variable>& ts, int64_t dim);
std::vector<Variable> split(const Variable& a, const std::vector<int64_t>& sizes, int64_t dim);
std::vector<Variable> chunk(const Variable& a, int64_t chunks, int64_t dim);

}  // namespace t2m::ag
