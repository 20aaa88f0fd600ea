// ops_linalg.h — differentiable matrix products.
//
// matmul(a, b): numpy rules — 1-D·1-D dot (0-d result); 2-D·2-D; 1-D operands are promoted ([k] -> [1, k] on the
// left, [k] -> [k, 1] on the right) and the added dim removed from the result; leading (batch) dims broadcast.
// matmul_t(a, ta, b, tb) = op(a) · op(b) with op transposing the last two dims when its flag is set; both
// operands at least 2-D; batch dims broadcast.
// Gradients: dA = g · op(B)^T and dB = op(A)^T · g, computed with matmul_t (no transposes materialised) and
// summed over broadcast batch dims. Errors: inner sizes differ or batch dims do not broadcast (tensor op).
#pragma once
#include "autograd/variable.h"

namespace t2m::ag {

Variable matmul(const Variable& a, const Variable& b);
Variable matmul_t(const Variable& a, bool trans_a, const Variable& b, bool trans_b);

}  // namespace t2m::ag
