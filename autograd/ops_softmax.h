// ops_softmax.h — softmax and log-softmax along one dim, differentiable (computed on a - max(a) along dim, so
// stable and precise for large inputs). out has a's shape.
//
// Gradients (y = softmax(a), g = output gradient, sums along dim with keepdim):
//   softmax:     da = y * (g - sum(g * y))
//   log_softmax: da = g - y * sum(g)
// Errors: dim out of range, or size 0 along dim (max of an empty axis) — t2m::Error from the tensor ops.
#pragma once
#include "autograd/variable.h"

namespace t2m::ag {

Variable softmax(const Variable& a, int64_t dim);
Variable log_softmax(const Variable& a, int64_t dim);

}  // namespace t2m::ag
