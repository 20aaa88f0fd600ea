// attention_ctx.h — multi-head cross-attention whose values are the context rows themselves: the core of a
// cross-attention that applies its value projection after the weighted sum. Attention is linear in its values, so
// for values V = ctx W_v^T + b_v (one head h: columns [h*d, (h+1)*d) of W_v's rows)
//   P_h V_h = (P_h ctx) W_v,h^T + (sum_s P_h[., s]) b_v,h,
// and when H * Tq is small against Tk's context width (the fm generator: 8 heads, 8 motion tokens, 24 text tokens
// of width 1024) the right side costs less than projecting every context row. This file computes the part
// between the projections: per head (b, h), the probabilities P (as attention_heads.h: q and k read in place from
// the projections' rows, optional QK RMS-norm and RoPE) and U[h, b] = P ctx_b; the backward takes dU.
//
// Layouts: q (B, Tq, ldq) and k (B, Tk, ldk) rows with each head's d columns at h*d after the pointer
// (AttentionHeads<T>; its v, ldv are not used); ctx (B, Tk, C) contiguous; u, du (H, B, Tq, C) contiguous (head-
// major, so that head h's rows over (b, t) are one (B*Tq, C) matrix for the value projection's GEMM); att
// (B, H, Tq, Tk). The heads are split over threads whole for P, (batch row, column block) items for U, the batch
// rows in the backward: every value is computed by one thread in a fixed order (bitwise identical for any thread
// count, except the norm-weight gradients, which add per-thread partials in thread order as attention_heads.h does).
// Serves the shapes attention_heads_eligible serves. Errors (t2m::Error): as attention_heads_forward/backward, plus
// C < 1 and a null ctx, u or du.
#pragma once
#include <cstdint>

#include "tensor/fused/attention_heads.h"

namespace t2m::fused {

// u (H, B, Tq, C) = P ctx per head; att (B, H, Tq, Tk) written; rstd_q (B*H*Tq), rstd_k (B*H*Tk) with QK-norm.
template <typename T>
void attention_ctx_forward(T* u, T* att, T* rstd_q, T* rstd_k, const AttentionHeads<T>& a, const T* ctx, int64_t C);

// u (H, B, Tq, C) = P ctx again from the forward's probabilities att (the same bits as attention_ctx_forward's u):
// the backward recomputes it rather than the forward keeping it (at fm-paper B256 Tm8 it is 64 MB per layer).
template <typename T>
void attention_ctx_values(T* u, const T* att, const AttentionShape& s, const T* ctx, int64_t C);

// du (H, B, Tq, C) -> written (=): dq (B, Tq, lddq), dk (B, Tk, lddk) at the heads' columns and dctx (B, Tk, C) =
// sum_h P^T du (the context's gradient through the weighted sum only); any may be null. Accumulated (+=): dq_norm,
// dk_norm (d), may be null.
template <typename T>
void attention_ctx_backward(T* dq, int64_t lddq, T* dk, int64_t lddk, T* dctx, T* dq_norm, T* dk_norm, const T* du,
                            const T* att, const T* rstd_q, const T* rstd_k, const AttentionHeads<T>& a, const T* ctx,
                            int64_t C);

// The same, compiled with AVX-512 (attention_ctx_avx512.cpp); call only where the CPU has it.
template <typename T>
void attention_ctx_forward_avx512(T* u, T* att, T* rstd_q, T* rstd_k, const AttentionHeads<T>& a, const T* ctx,
                                  int64_t C);
template <typename T>
void attention_ctx_values_avx512(T* u, const T* att, const AttentionShape& s, const T* ctx, int64_t C);
template <typename T>
void attention_ctx_backward_avx512(T* dq, int64_t lddq, T* dk, int64_t lddk, T* dctx, T* dq_norm, T* dk_norm,
                                   const T* du, const T* att, const T* rstd_q, const T* rstd_k,
                                   const AttentionHeads<T>& a, const T* ctx, int64_t C);

}  // namespace t2m::fused
