// ops_mha.h — the core of multi-head attention as ONE differentiable op: split the projected rows into heads
// (one layout change into the fused kernels' (B, H, T, d) layout), optional QK RMS-norm per head (learnable
// weight of size d shared by all heads), optional RoPE on q and k, scaled dot-product attention with key mask
// and causal option, and the merge of the heads back to (B, Tq, H*d). The projections (Linear) stay outside.
// It computes exactly what SelfAttention/CrossAttention of ../shared/anchor/torch_ref.py compute between their
// input Linear and their output Linear:
//   q, k, v = heads(...); q, k = qn(q), kn(k); q, k = rope(q), rope(k); o = softmax(q k^T / sqrt d) v; merge(o)
// RMS-norm: y = x / sqrt(mean(x^2) + eps) * w over each head vector. RoPE: rotate-half, positions pos0 + t.
//
// Self:  qkv (B, T, 3*H*d) — the fused projection, columns [q | k | v], each H heads of d  ->  (B, T, H*d).
// Cross: q (B, Tq, H*d), kv (B, Tk, 2*H*d) — columns [k | v]  ->  (B, Tq, H*d).
// q_norm / k_norm: both undefined (no QK norm) or both (d) Variables. key_mask: undefined or (B, Tk), any dtype,
// nonzero = visible. causal needs Tq == Tk (self only). Inputs of any strides (copied once when not contiguous).
// Shapes the small-head attention serves (tensor/fused/attention_heads.h: the fm generator's) run fused per head
// straight from the input rows into the output rows, and back into the input gradient; the node keeps the inputs,
// the rstd of the QK-norm and the (B, H, Tq, Tk) probabilities (q/k are normed and rotated again per head in the
// backward). Other shapes split the heads into (B, H, T, d) copies and save the pre-norm q/k heads and their rstd
// (with QK-norm; the normed, rotated q/k are recomputed in the backward) or the rotated q/k (without), v and the
// probabilities.
// Backward writes the gradient of the packed input directly (no zero-fill, no per-part scatter-and-add).
// Errors (t2m::Error, message starts "mha_self:"/"mha_cross:" and names the shapes): wrong ranks, a last dim
// that is not 3*H*d / H*d / 2*H*d, B mismatch, H < 1, odd d with rope, only one norm weight or one not of size d,
// dtype mismatch, key_mask not (B, Tk), causal with Tq != Tk.
#pragma once
#include <cstdint>

#include "autograd/variable.h"

namespace t2m::ag {

struct MhaOptions {
  int64_t heads = 1;
  double norm_eps = 1e-6;   // QK RMS-norm epsilon (torch_ref.py: 1e-6)
  bool rope = false;        // rotate q and k (self-attention)
  int64_t rope_pos0 = 0;    // position of the first query/key
  double rope_base = 10000.0;
  bool causal = false;
};

Variable mha_self(const Variable& qkv, const Variable& q_norm, const Variable& k_norm, const Tensor& key_mask,
                  const MhaOptions& opt);

Variable mha_cross(const Variable& q, const Variable& kv, const Variable& q_norm, const Variable& k_norm,
                   const Tensor& key_mask, const MhaOptions& opt);

}  // namespace t2m::ag
