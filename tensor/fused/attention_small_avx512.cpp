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
