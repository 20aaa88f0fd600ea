// ops_unary.h — differentiable unary elementwise ops. out and every gradient have a's shape and dtype.
//
// Domains follow the math (log/sqrt/rsqrt/reciprocal of values <= 0 give NaN/inf, no Error).
// Non-smooth points: relu'(0) = 0, abs'(0) = 0 (sign), clamp passes the gradient where lo <= a <= hi (inclusive).
// clamp: Error when lo > hi (from the tensor op).
#pragma once
#include "autograd/variable.h"

namespace t2m::ag {

Variable neg(const Variable& a);
Variable exp(const Variable& a);
Variable log(const Variable& a);
Variable sqrt(const Variable& a);
Variable rsqrt(const Variable& a);
Variable tanh(const Variable& a);
Variable sigmoid(const Variable& a);
Variable relu(const Variable& a);
Variable abs(const Variable& a);
Variable sin(const Variable& a);
Variable cos(const Variable& a);
Variable square(const Variable& a);
Variable reciprocal(const Variable& a);
Variable clamp(const Variable& a, double lo, double hi);
// sign(a) in {-1, 0, 1}: piecewise constant, so its gradient is zero everywhere (as in PyTorch).
Variable sign(const Variable& a);

}  // namespace t2m::ag
