// attention_small.cpp — the small-head path's entry points: the AVX-512 build of the per-head loops
// (attention_small_avx512.cpp) where the CPU has it, else the baseline build of the same loops (this file).
#pragma GCC optimize("no-trapping-math")
#include "tensor/fused/attention_small.h"

#include "tensor/cpu_features.h"
#include "tensor/fused/attention_small_kernels.h"

namespace t2m::fused {

bool attention_small_eligible(const AttentionShape& s) { return s.Tq * s.Tk <= kSmallAttentionTile && s.d <= 256; }

template <typename T>
void attention_small_forward(T* out, T* att, const T* q, const T* k, const T* v, const T* key_mask,
                             const AttentionShape& s) {
  if (use_avx512_kernels()) return attention_small_forward_avx512(out, att, q, k, v, key_mask, s);
  small_forward_all(out, att, q, k, v, key_mask, s);
}

template <typename T>
void attention_small_backward(T* dq, T* dk, T* dv, const T* dout, const T* att, const T* q, const T* k, const T* v,
                              const AttentionShape& s) {
  if (use_avx512_kernels()) return attention_small_backward_avx512(dq, dk, dv, dout, att, q, k, v, s);
  small_backward_all(dq, dk, dv, dout, att, q, k, v, s);
}

template <typename T>
void attention_small_heads_forward(T* out, int64_t ldo, T* att, T* rstd_q, T* rstd_k, const AttentionHeads<T>& a) {
  if (use_avx512_kernels()) return attention_small_heads_forward_avx512(out, ldo, att, rstd_q, rstd_k, a);
  small_heads_forward_all(out, ldo, att, rstd_q, rstd_k, a);
}

template <typename T>
void attention_small_heads_backward(T* dq, int64_t lddq, T* dk, int64_t lddk, T* dv, int64_t lddv, T* dq_norm,
                                    T* dk_norm, const T* dout, int64_t ldg, const T* att, const T* rstd_q,
                                    const T* rstd_k, const AttentionHeads<T>& a) {
  if (use_avx512_kernels())
    return attention_small_heads_backward_avx512(dq, lddq, dk, lddk, dv, lddv, dq_norm, dk_norm, dout, ldg, att,
                                                 rstd_q, rstd_k, a);
  small_heads_backward_all(dq, lddq, dk, lddk, dv, lddv, dq_norm, dk_norm, dout, ldg, att, rstd_q, rstd_k, a);
}

#define T2M_HEADS_INSTANTIATE(T)                                                                                   \
  template void attention_small_heads_forward<T>(T*, int64_t, T*, T*, T*, const AttentionHeads<T>&);             \
  template void attention_small_heads_backward<T>(T*, int64_t, T*, int64_t, T*, int64_t, T*, T*, const T*,        \
                                                  int64_t, const T*, const T*, const T*, const AttentionHeads<T>&);
T2M_HEADS_INSTANTIATE(float)
T2M_HEADS_INSTANTIATE(double)
#undef T2M_HEADS_INSTANTIATE

template void attention_small_forward<float>(float*, float*, const float*, const float*, const float*, const float*,
                                             const AttentionShape&);
template void attention_small_forward<double>(double*, double*, const double*, const double*, const double*,
                                              const double*, const AttentionShape&);
template void attention_small_backward<float>(float*, float*, float*, const float*, const float*, const float*,
                                              const float*, const float*, const AttentionShape&);
template void attention_small_backward<double>(double*, double*, double*, const double*, const double*,
                                               const double*, const double*, const double*, const AttentionShape&);

}  // namespace t2m::fused
