// gelu_tanh_avx512.cpp — the loops of gelu_tanh_kernels.h compiled with AVX-512 (this file name gets the flags from
// CMakeLists.txt); gelu_tanh.cpp calls them only where use_avx512_kernels().
#pragma GCC optimize("no-trapping-math")
#include "tensor/fused/gelu_tanh_kernels.h"

namespace t2m::fused {

template <typename T>
void gelu_forward_chunk_avx512(T* out, const T* inp, int64_t n) {
  gelu_forward_chunk(out, inp, n);
}

template <typename T>
void gelu_backward_chunk_avx512(T* dinp, const T* dout, const T* inp, int64_t n) {
  gelu_backward_chunk(dinp, dout, inp, n);
}

template void gelu_forward_chunk_avx512<float>(float*, const float*, int64_t);
template void gelu_forward_chunk_avx512<double>(double*, const double*, int64_t);
template void gelu_backward_chunk_avx512<float>(float*, const float*, const float*, int64_t);
template void gelu_backward_chunk_avx512<double>(double*, const double*, const double*, int64_t);

}  // namespace t2m::fused
