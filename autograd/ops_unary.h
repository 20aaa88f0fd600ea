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
// The ReLU's backward as a tensor kernel: g * (ref > 0) in one pass, where ref is the ReLU's input or its output
// (the same mask: the output is > 0 exactly where the input is; NaN and -0 give 0). g and ref: one shape, f32 or
// f64, the same dtype. Used by relu and by fused ops that end in a ReLU (nn::linear_relu).
Tensor relu_grad(const Tensor& g, const Tensor& ref);
Variable abs(const Variable& a);
Variable sin(const Variable& a);
Variable cos(const Variable& a);
Variable square(const Variable& a);
Variable reciprocal(const Variable& a);
Variable clamp(const Variable& a, double lo, double hi);
// sign(a) in {-1, 0, 1}: piecewise constant, so its gradient is zero everywhere (as in PyTorch).
Variable sign(const Variable& a);

}  // namespace t2m::ag
