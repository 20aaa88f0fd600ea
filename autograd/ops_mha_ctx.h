// ops_mha_ctx.h — cross-attention with the value projection applied after the weighted sum, as ONE differentiable
// op from the projected queries and the raw context (tensor/fused/attention_ctx.h has the identity it rests on):
//   K = ctx W_k^T + b_k                      (one GEMM over the context rows; W_k, b_k: rows [0, D) of kv)
//   P_h = softmax(qn(q_h) kn(K_h)^T / sqrt d) (QK RMS-norm optional, key mask)
//   U_h = P_h ctx,  o_h = U_h W_v,h^T + (sum_s P_h) b_v,h   (W_v, b_v: rows [D, 2D) of kv; one GEMM per head)
// It computes what mha_cross(q, Linear(kv)(ctx), q_norm, k_norm, key_mask) computes (ops_mha.h: the same function
// and gradients up to rounding) with Tk*C*D + H*Tq*Tk*C + Tq*C*D multiply-adds per batch row for K, U and o instead
// of 2*Tk*C*D + 2*Tq*Tk*D for K, V and P V: less when H*Tq is small against the context width C (the fm-paper
// generator at Tm = 8: 8 heads x 8 frames against 24 tokens of width 1024 take 27 % fewer in this block).
//
// q (B, Tq, D) with D = H*d; ctx (B, Tk, C); kv_weight (2D, C) and kv_bias (2D) or undefined, as the kv Linear of
// nn::MultiheadAttention holds them; q_norm/k_norm (d) both or neither; key_mask (B, Tk) or undefined, nonzero =
// visible. Output (B, Tq, D): the merged heads, before the output projection. Gradients of all six inputs.
// Saved for the backward: q, ctx, the weight, K, the probabilities and their row sums; U (H, B, Tq, C), 4x the
// size of K at fm-paper Tm 8, is recomputed from them (~8 % of the block's forward multiply-adds) rather than kept,
// so that peak memory stays below the K/V-projection form's.
// Errors (t2m::Error, message starts "mha_cross_ctx:" and names the shapes): wrong ranks or sizes, dtype mismatch,
// a shape the fused heads path does not serve (mha_cross_ctx_serves), rope or causal options.
#pragma once
#include <cstdint>

#include "autograd/ops_mha.h"
#include "autograd/variable.h"

namespace t2m::ag {

Variable mha_cross_ctx(const Variable& q, const Variable& ctx, const Variable& kv_weight, const Variable& kv_bias,
                       const Variable& q_norm, const Variable& k_norm, const Tensor& key_mask, const MhaOptions& opt);

// Whether mha_cross_ctx serves a cross-attention of Tq queries over Tk keys with H heads of d (its fused per-head
// loops' shapes).
bool mha_cross_ctx_serves(int64_t Tq, int64_t Tk, int64_t H, int64_t d);

// Whether a cross-attention (Tq queries, Tk context rows of width C, D = H*d) should take mha_cross_ctx: served and
// at most 4/5 of the multiply-adds of the K/V-projection form (K, V, Q K^T, P V against K, Q K^T, U, o), unless
// forced. The fm-paper generator: yes at Tm = 8 (0.73), no at Tm = 16 (0.95).
bool mha_cross_ctx_chosen(int64_t Tq, int64_t Tk, int64_t C, int64_t H, int64_t d);

// Force the choice (tests, benchmarks): "auto" (the cost rule), "always" (whenever served) or "never".
void mha_cross_ctx_force(const char* mode);

}  // namespace t2m::ag
