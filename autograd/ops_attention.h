// ops_attention.h — differentiable scaled dot-product attention and rotary position embedding (RoPE), each one
// op backed by a fused kernel (tensor/fused/attention.h, tensor/fused/rope.h). float32 and float64.
//
// attention(q, k, v, key_mask, causal) = softmax(q k^T / sqrt(d)) v   (Vaswani et al. 2017, Eq 1)
//   q (B, H, Tq, d), k and v (B, H, Tk, d)  ->  out (B, H, Tq, d), a fresh contiguous tensor.
//   key_mask: undefined, or a (B, Tk) tensor of any dtype; nonzero = the key is visible, 0 = masked (masked keys
//   get probability exactly 0, like an additive -inf bias). causal (needs Tq == Tk): query i sees keys j <= i.
//   A query row with no visible key gives output 0 and no gradient (not NaN).
//   Inputs of any strides are accepted (copied to contiguous once when needed). The node keeps q, k, v and the
//   (B, H, Tq, Tk) probabilities for the backward; only the gradients asked for are computed.
//   Errors (t2m::Error, message starts "attention:" and names the shapes): q/k/v not 4-D, B/H/d disagreeing,
//   k and v of different shapes, non-float or mixed dtypes, key_mask not (B, Tk), causal with Tq != Tk.
//
// rope(x, pos0, base): rotate-half RoPE (RoFormer) over the last dim, positions pos0, pos0+1, ... along dim -2.
//   x (..., T, d) with d even (typically (B, H, T, d))  ->  out of x's shape. Pair (i, i + d/2) is rotated by
//   angle pos * base^(-2i/d). Backward: the rotation by the opposite angle.
//   Errors (t2m::Error, message starts "rope:"): fewer than 2 dims, odd d, non-float dtype, pos0 < 0.
#pragma once
#include <cstdint>

#include "autograd/variable.h"

namespace t2m::ag {

Variable attention(const Variable& q, const Variable& k, const Variable& v, const Tensor& key_mask = Tensor(),
                   bool causal = false);

Variable rope(const Variable& x, int64_t pos0 = 0, double base = 10000.0);

}  // namespace t2m::ag
