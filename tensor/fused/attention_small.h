// attention_small.h — INTERNAL to tensor/fused/: scaled dot-product attention for many small heads (the fm
// generator's Tm = 8..16 motion frames and 24 text tokens at d = 32..96), one head at a time, all in L1: for
// d = 32/64/96/128 every product (scores, P V, P^T dO, dP, dS K, dS^T Q) is a register-blocked row sum, the scores
// and dP over a transposed copy of K or V; other d run dot products and axpys. gemm_batched packs panels per head,
// which costs more than the arithmetic at these sizes (QK^T at B256 H8 T16 d64: 6.3 ms against 1.7 ms in plain
// loops). On the AMD host the register blocking made B256 H4 Tq16 Tk24 d64 1.8x (forward) and 2.0x (backward)
// faster than the dot/axpy loops (tensor/fused microbenchmark, 2 threads).
// Same contract and results (up to summation order) as attention_forward/attention_backward (attention.h); heads
// are split over threads whole, so every value is computed by one thread in a fixed order: bitwise identical for
// any thread count.
#pragma once
#include <cstdint>

#include "tensor/fused/attention.h"
#include "tensor/fused/attention_heads.h"

namespace t2m::fused {

// Whether the small-head path serves shape s (Tq * Tk <= kSmallAttentionTile and d <= 256).
constexpr int64_t kSmallAttentionTile = 64 * 64;
bool attention_small_eligible(const AttentionShape& s);

template <typename T>
void attention_small_forward(T* out, T* att, const T* q, const T* k, const T* v, const T* key_mask,
                             const AttentionShape& s);

template <typename T>
void attention_small_backward(T* dq, T* dk, T* dv, const T* dout, const T* att, const T* q, const T* k, const T* v,
                              const AttentionShape& s);

// attention_heads_forward/backward (attention_heads.h) after their argument checks.
template <typename T>
void attention_small_heads_forward(T* out, int64_t ldo, T* att, T* rstd_q, T* rstd_k, const AttentionHeads<T>& a);
template <typename T>
void attention_small_heads_backward(T* dq, int64_t lddq, T* dk, int64_t lddk, T* dv, int64_t lddv, T* dq_norm,
                                    T* dk_norm, const T* dout, int64_t ldg, const T* att, const T* rstd_q,
                                    const T* rstd_k, const AttentionHeads<T>& a);

// The same loops compiled with AVX-512 (attention_small_avx512.cpp); call only where the CPU supports it.
template <typename T>
void attention_small_forward_avx512(T* out, T* att, const T* q, const T* k, const T* v, const T* key_mask,
                                    const AttentionShape& s);
template <typename T>
void attention_small_heads_forward_avx512(T* out, int64_t ldo, T* att, T* rstd_q, T* rstd_k,
                                          const AttentionHeads<T>& a);
template <typename T>
void attention_small_heads_backward_avx512(T* dq, int64_t lddq, T* dk, int64_t lddk, T* dv, int64_t lddv,
                                           T* dq_norm, T* dk_norm, const T* dout, int64_t ldg, const T* att,
                                           const T* rstd_q, const T* rstd_k, const AttentionHeads<T>& a);
template <typename T>
void attention_small_backward_avx512(T* dq, T* dk, T* dv, const T* dout, const T* att, const T* q, const T* k,
                                     const T* v, const AttentionShape& s);

}  // namespace t2m::fused
