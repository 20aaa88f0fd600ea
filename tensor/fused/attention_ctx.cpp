// attention_ctx.cpp — attention_ctx.h's entry points: argument checks, then the AVX-512 build of the loops
// (attention_ctx_avx512.cpp) where the CPU has it, else the baseline build of the same loops (this file).
#pragma GCC optimize("no-trapping-math")
#include "tensor/fused/attention_ctx.h"

#include <string>

#include "tensor/cpu_features.h"
#include "tensor/fused/attention_ctx_kernels.h"

namespace t2m::fused {

namespace {

// The checks of attention_heads.h without the values, plus the context.
template <typename T>
void check_ctx(const char* op, const AttentionHeads<T>& a, const T* ctx, int64_t C) {
  check_attention_heads(op, a, false);
  check_dim(op, "C", C, 1);
  if (a.s.B > 0) check_ptr(op, "ctx", ctx);
}

}  // namespace

template <typename T>
void attention_ctx_forward(T* u, T* att, T* rstd_q, T* rstd_k, const AttentionHeads<T>& a, const T* ctx, int64_t C) {
  const char* op = "attention_ctx_forward";
  check_ctx(op, a, ctx, C);
  if (a.s.B == 0) return;
  check_ptr(op, "u", u);
  check_ptr(op, "att", att);
  if (a.q_norm) {
    check_ptr(op, "rstd_q", rstd_q);
    check_ptr(op, "rstd_k", rstd_k);
  }
  if (use_avx512_kernels()) return attention_ctx_forward_avx512(u, att, rstd_q, rstd_k, a, ctx, C);
  ctx_forward_all(u, att, rstd_q, rstd_k, a, ctx, C);
}

template <typename T>
void attention_ctx_values(T* u, const T* att, const AttentionShape& s, const T* ctx, int64_t C) {
  const char* op = "attention_ctx_values";
  check_dim(op, "B", s.B, 0);
  check_dim(op, "H", s.H, 1);
  check_dim(op, "Tq", s.Tq, 1);
  check_dim(op, "Tk", s.Tk, 1);
  check_dim(op, "C", C, 1);
  if (s.B == 0) return;
  check_ptr(op, "u", u);
  check_ptr(op, "att", att);
  check_ptr(op, "ctx", ctx);
  if (use_avx512_kernels()) return attention_ctx_values_avx512(u, att, s, ctx, C);
  ctx_values_all(u, att, s, ctx, C);
}

template <typename T>
void attention_ctx_backward(T* dq, int64_t lddq, T* dk, int64_t lddk, T* dctx, T* dq_norm, T* dk_norm, const T* du,
                            const T* att, const T* rstd_q, const T* rstd_k, const AttentionHeads<T>& a, const T* ctx,
                            int64_t C) {
  const char* op = "attention_ctx_backward";
  check_ctx(op, a, ctx, C);
  if (a.s.B == 0) return;
  check_ptr(op, "du", du);
  check_ptr(op, "att", att);
  const int64_t w = a.s.H * a.s.d;
  if ((dq && lddq < w) || (dk && lddk < w))
    throw Error(std::string(op) + ": leading dimensions must be >= H*d = " + std::to_string(w));
  if (a.q_norm) {
    check_ptr(op, "rstd_q", rstd_q);
    check_ptr(op, "rstd_k", rstd_k);
  } else {
    dq_norm = dk_norm = nullptr;
  }
  if (use_avx512_kernels())
    return attention_ctx_backward_avx512(dq, lddq, dk, lddk, dctx, dq_norm, dk_norm, du, att, rstd_q, rstd_k, a, ctx,
                                         C);
  ctx_backward_all(dq, lddq, dk, lddk, dctx, dq_norm, dk_norm, du, att, rstd_q, rstd_k, a, ctx, C);
}

#define T2M_CTX_INSTANTIATE(T)                                                                                     \
  template void attention_ctx_forward<T>(T*, T*, T*, T*, const AttentionHeads<T>&, const T*, int64_t);            \
  template void attention_ctx_values<T>(T*, const T*, const AttentionShape&, const T*, int64_t);                   \
  template void attention_ctx_backward<T>(T*, int64_t, T*, int64_t, T*, T*, T*, const T*, const T*, const T*,      \
                                          const T*, const AttentionHeads<T>&, const T*, int64_t);
T2M_CTX_INSTANTIATE(float)
T2M_CTX_INSTANTIATE(double)
#undef T2M_CTX_INSTANTIATE

}  // namespace t2m::fused
