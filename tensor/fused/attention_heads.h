// attention_heads.h — multi-head attention read from and written to the projections' own (B, T, W) rows: head h of
// row (b, t) is the d columns [h*d, (h+1)*d) after the array's pointer (so a pointer at column col of a packed
// [q | k | v] projection selects its q, k or v). Per head, q and k are gathered into thread-local scratch and
// get the optional QK RMS-norm (rms_norm.h) and RoPE (rope.h) there; the small-head attention loops
// (attention_small.h) then read v and write the output in place. No (B, H, T, d) copy of q, k, v or the output
// exists, and each large array is written once. The backward does the same per head and writes dv, and dq/dk
// through the RoPE and RMS-norm backward, straight into the gradient of the projections.
//
// Same values as gather heads -> rms_norm_forward -> rope_forward -> attention_forward -> merge heads, and the
// matching backward: the same row kernels in the same order. The norm-weight gradients add per-thread partials
// over contiguous head ranges in thread order, as rms_norm_backward does over rows: deterministic for a thread
// count, and bit-identical to the unfused path when the head split and the row split coincide (an even B*H on 2
// threads).
// Serves the small path's shapes only (attention_heads_eligible); callers keep the (B, H, T, d) path for others.
// Scratch (thread-local): slot 3, (Tq + Tk) * d elements (norm or RoPE only); the backward also slot 0
// (nthreads * 2d, the norm-weight partials) and slot 4 ((Tq + Tk + 1) * d).
// Errors: t2m::Error as attention_forward/backward, and for a shape the path does not serve, a leading dimension
// smaller than H*d, one norm weight without the other, RoPE with Tq != Tk, null required pointers.
#pragma once
#include <cstdint>

#include "tensor/fused/attention.h"

namespace t2m::fused {

// The inputs of one call. q (B, Tq, ldq) and k, v (B, Tk, ldk / ldv) rows, each pointer at its first head's column.
template <typename T>
struct AttentionHeads {
  AttentionShape s;
  const T *q = nullptr, *k = nullptr, *v = nullptr;
  int64_t ldq = 0, ldk = 0, ldv = 0;
  const T* key_mask = nullptr;                  // (B, Tk), nonzero = visible, or null
  const T *q_norm = nullptr, *k_norm = nullptr;  // QK RMS-norm weights (d), both or neither
  T norm_eps = 0;
  const T *cos_tab = nullptr, *sin_tab = nullptr;  // RoPE tables (Tq, d/2) (rope.h), both or neither; Tq == Tk
};

// out (B, Tq, ldo) rows written at the heads' columns; att (B, H, Tq, Tk) probabilities (keep for the backward);
// rstd_q (B*H*Tq) and rstd_k (B*H*Tk) written with QK-norm (else may be null).
template <typename T>
void attention_heads_forward(T* out, int64_t ldo, T* att, T* rstd_q, T* rstd_k, const AttentionHeads<T>& a);

// dout (B, Tq, ldg) rows; att, rstd_q, rstd_k from the forward. Written (=): dq (B, Tq, lddq), dk (B, Tk, lddk),
// dv (B, Tk, lddv) at the heads' columns, any may be null. Accumulated (+=): dq_norm, dk_norm (d), may be null.
template <typename T>
void attention_heads_backward(T* dq, int64_t lddq, T* dk, int64_t lddk, T* dv, int64_t lddv, T* dq_norm, T* dk_norm,
                              const T* dout, int64_t ldg, const T* att, const T* rstd_q, const T* rstd_k,
                              const AttentionHeads<T>& a);

// The argument checks of attention_heads_forward/backward (t2m::Error naming op): the shape (as attention_forward),
// served by the fused path, leading dimensions >= H*d, norm weights and RoPE tables in pairs, RoPE with Tq == Tk and
// an even d, norm_eps >= 0, and (B > 0) q and k non-null; v and ldv too when `values` (attention_ctx.h has none).
template <typename T>
void check_attention_heads(const char* op, const AttentionHeads<T>& a, bool values);

// Whether the fused path serves s (the small path's shapes, and attention_force_path not "gemm").
bool attention_heads_eligible(const AttentionShape& s);

}  // namespace t2m::fused
