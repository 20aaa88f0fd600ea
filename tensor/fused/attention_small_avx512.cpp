// attention_small_avx512.cpp — the per-head attention loops (attention_small_kernels.h) compiled with AVX-512
// (this file name gets the AVX-512 flags from CMakeLists.txt); called by attention_small.cpp only on CPUs with it.
#pragma GCC optimize("no-trapping-math")
#include "tensor/fused/attention_small_kernels.h"

namespace t2m::fused {

template <typename T>
void attention_small_forward_avx512(T* out, T* att, const T* q, const T* k, const T* v, const T* key_mask,
                                    const AttentionShape& s) {
  small_forward_all(out, att, q, k, v, key_mask, s);
}

template <typename T>
void attention_small_backward_avx512(T* dq, T* dk, T* dv, const T* dout, const T* att, const T* q, const T* k,
                                     const T* v, const AttentionShape& s) {
  small_backward_all(dq, dk, dv, dout, att, q, k, v, s);
}

template <typename T>
void attention_small_heads_forward_avx512(T* out, int64_t ldo, T* att, T* rstd_q, T* rstd_k,
                                          const AttentionHeads<T>& a) {
  small_heads_forward_all(out, ldo, att, rstd_q, rstd_k, a);
}

template <typename T>
void attention_small_heads_backward_avx512(T* dq, int64_t lddq, T* dk, int64_t lddk, T* dv, int64_t lddv,
                                           T* dq_norm, T* dk_norm, const T* dout, int64_t ldg, const T* att,
                                           const T* rstd_q, const T* rstd_k, const AttentionHeads<T>& a) {
  small_heads_backward_all(dq, lddq, dk, lddk, dv, lddv, dq_norm, dk_norm, dout, ldg, att, rstd_q, rstd_k, a);
}

#define T2M_HEADS_INSTANTIATE(T)                                                                                   \
  template void attention_small_heads_forward_avx512<T>(T*, int64_t, T*, T*, T*, const AttentionHeads<T>&);      \
  template void attention_small_heads_backward_avx512<T>(T*, int64_t, T*, int64_t, T*, int64_t, T*, T*, const T*, \
                                                         int64_t, const T*, const T*, const T*,                   \
                                                         const AttentionHeads<T>&);
T2M_HEADS_INSTANTIATE(float)
T2M_HEADS_INSTANTIATE(double)
#undef T2M_HEADS_INSTANTIATE

template void attention_small_forward_avx512<float>(float*, float*, const float*, const float*, const float*,
                                                    const float*, const AttentionShape&);
template void attention_small_forward_avx512<double>(double*, double*, const double*, const double*, const double*,
                                                     const double*, const AttentionShape&);
template void attention_small_backward_avx512<float>(float*, float*, float*, const float*, const float*,
                                                     const float*, const float*, const float*, const AttentionShape&);
template void attention_small_backward_avx512<double>(double*, double*, double*, const double*, const double*,
                                                      const double*, const double*, const double*,
                                                      const AttentionShape&);

}  // namespace t2m::fused
