// attention_ctx_avx512.cpp — the loops of attention_ctx.h (attention_ctx_kernels.h) compiled with AVX-512 (this file
// name gets the AVX-512 flags from CMakeLists.txt); called by attention_ctx.cpp only on CPUs with it.
#pragma GCC optimize("no-trapping-math")
#include "tensor/fused/attention_ctx_kernels.h"

namespace t2m::fused {

template <typename T>
void attention_ctx_forward_avx512(T* u, T* att, T* rstd_q, T* rstd_k, const AttentionHeads<T>& a, const T* ctx,
                                  int64_t C) {
  ctx_forward_all(u, att, rstd_q, rstd_k, a, ctx, C);
}

template <typename T>
void attention_ctx_values_avx512(T* u, const T* att, const AttentionShape& s, const T* ctx, int64_t C) {
  ctx_values_all(u, att, s, ctx, C);
}

template <typename T>
void attention_ctx_backward_avx512(T* dq, int64_t lddq, T* dk, int64_t lddk, T* dctx, T* dq_norm, T* dk_norm,
                                   const T* du, const T* att, const T* rstd_q, const T* rstd_k,
                                   const AttentionHeads<T>& a, const T* ctx, int64_t C) {
  ctx_backward_all(dq, lddq, dk, lddk, dctx, dq_norm, dk_norm, du, att, rstd_q, rstd_k, a, ctx, C);
}

#define T2M_CTX_INSTANTIATE(T)                                                                                     \
  template void attention_ctx_forward_avx512<T>(T*, T*, T*, T*, const AttentionHeads<T>&, const T*, int64_t);     \
  template void attention_ctx_values_avx512<T>(T*, const T*, const AttentionShape&, const T*, int64_t);           \
  template void attention_ctx_backward_avx512<T>(T*, int64_t, T*, int64_t, T*, T*, T*, const T*, const T*,        \
                                                 const T*, const T*, const AttentionHeads<T>&, const T*, int64_t);
T2M_CTX_INSTANTIATE(float)
T2M_CTX_INSTANTIATE(double)
#undef T2M_CTX_INSTANTIATE

}  // namespace t2m::fused
