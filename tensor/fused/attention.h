// attention.h — scaled dot-product attention (Vaswani et al. 2017, Eq 1): softmax(Q K^T / sqrt(d)) V over
// (B, H, T, d) heads, with an optional key-padding mask and an optional causal mask.
//
// q (B, H, Tq, d), k/v (B, H, Tk, d) contiguous; out (B, H, Tq, d); att (B, H, Tq, Tk) receives the softmax
// probabilities and must be kept for the backward. key_mask (B, Tk) or null: nonzero = keep, 0 = masked (the
// same effect as an additive -inf bias: masked keys get probability exactly 0). causal (needs Tq == Tk): query
// i sees keys j <= i. A query row with no visible key gets probabilities 0 and output 0 (not NaN), and no
// gradient.
// Backward writes dq/dk/dv (=); any of them may be null to skip.
// Scratch (thread-local): slot 2, B*H*Tq*Tk elements (dS) in the backward.
// Two implementations: many small heads (Tq * Tk <= 4096, d <= 256: the fm generator's shapes) run per head in
// plain loops (attention_small.h; bitwise identical for any thread count); larger heads use three
// t2m::gemm_batched products per direction (deterministic for a fixed thread count).
// Errors: t2m::Error for sizes < 1 (B may be 0), causal with Tq != Tk, null required pointers.
#pragma once
#include <cstdint>

namespace t2m::fused {

struct AttentionShape {
  int64_t B = 1, H = 1, Tq = 1, Tk = 1, d = 1;
  bool causal = false;
};

// q (B,H,Tq,d), k/v (B,H,Tk,d), key_mask (B,Tk) or null; out (B,H,Tq,d), att (B,H,Tq,Tk) written.
template <typename T>
void attention_forward(T* out, T* att, const T* q, const T* k, const T* v, const T* key_mask,
                       const AttentionShape& s);

// dout (B,H,Tq,d), att from the forward, q/k/v as in the forward; dq (B,H,Tq,d), dk/dv (B,H,Tk,d) written.
template <typename T>
void attention_backward(T* dq, T* dk, T* dv, const T* dout, const T* att, const T* q, const T* k, const T* v,
                        const AttentionShape& s);

// The implementation attention_forward/backward use for s: "small" or "gemm". attention_force_path("small" |
// "gemm" | "auto") overrides the choice process-wide (tests, benchmarks); "small" still falls back to "gemm" for
// shapes it cannot serve. Error for another name.
const char* attention_path(const AttentionShape& s);
void attention_force_path(const char* name);

// FLOPs of the forward GEMMs (4 * B*H*Tq*Tk*d); the backward does twice that.
double attention_forward_flops(const AttentionShape& s);

}  // namespace t2m::fused
