// ops_elementwise.h — differentiable binary elementwise ops with numpy broadcasting, scalar forms, selection
// (where/masked_fill), non-differentiable comparisons, and the Variable operators + - * / and unary -.
//
// Shapes: a is A, b is B, out is broadcast_shapes(A, B); each input gradient is summed back to its own shape
// (t2m::sum_to). Both inputs must share a float dtype (else Error from the tensor op). Errors: incompatible
// shapes throw t2m::Error naming the op and both shapes.
// Non-smooth points: maximum/minimum split the gradient evenly between a and b where a == b.
// pow(a, b): the gradient to b is out * log(a), defined for a > 0 only (NaN elsewhere, as in the math).
#pragma once
#include "autograd/variable.h"

namespace t2m::ag {

Variable add(const Variable& a, const Variable& b);
Variable sub(const Variable& a, const Variable& b);
Variable mul(const Variable& a, const Variable& b);
Variable div(const Variable& a, const Variable& b);
Variable pow(const Variable& a, const Variable& b);
Variable maximum(const Variable& a, const Variable& b);
Variable minimum(const Variable& a, const Variable& b);

// with a scalar s
Variable add(const Variable& a, double s);       // a + s
Variable sub(const Variable& a, double s);       // a - s
Variable rsub(double s, const Variable& a);      // s - a
Variable mul(const Variable& a, double s);       // a * s
Variable div(const Variable& a, double s);       // a / s   (s == 0 gives inf, like the math)
Variable rdiv(double s, const Variable& a);      // s / a
Variable pow(const Variable& a, double exponent);

// where(cond, a, b): cond != 0 picks a, else b (all broadcast together); the gradient flows to the picked branch.
Variable where(const Tensor& cond, const Variable& a, const Variable& b);
// masked_fill(a, mask, value): value where mask != 0 (mask broadcast to a); no gradient flows there.
Variable masked_fill(const Variable& a, const Tensor& mask, double value);

// Comparisons are not differentiable: 0/1 masks of a's dtype.
Tensor gt(const Variable& a, const Variable& b);
Tensor lt(const Variable& a, const Variable& b);
Tensor ge(const Variable& a, const Variable& b);
Tensor le(const Variable& a, const Variable& b);
Tensor eq(const Variable& a, const Variable& b);
Tensor gt(const Variable& a, double s);
Tensor lt(const Variable& a, double s);

Variable operator+(const Variable& a, const Variable& b);
Variable operator-(const Variable& a, const Variable& b);
Variable operator*(const Variable& a, const Variable& b);
Variable operator/(const Variable& a, const Variable& b);
Variable operator-(const Variable& a);
Variable operator+(const Variable& a, double s);
Variable operator+(double s, const Variable& a);
Variable operator-(const Variable& a, double s);
Variable operator-(double s, const Variable& a);
Variable operator*(const Variable& a, double s);
Variable operator*(double s, const Variable& a);
Variable operator/(const Variable& a, double s);
Variable operator/(double s, const Variable& a);

}  // namespace t2m::ag
