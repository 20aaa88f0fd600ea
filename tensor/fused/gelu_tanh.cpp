// gelu_tanh.cpp — argument checks and the thread split; each thread's chunk runs the AVX-512 build of the loops
// (gelu_tanh_avx512.cpp) where the CPU has it, else the baseline build (gelu_tanh_kernels.h, compiled here).
// Comparisons in the clamps of exp_approx may not be if-converted (vectorised) under the default -ftrapping-math;
// no kernel here reads the floating-point exception flags, so trapping semantics are dropped for this file.
#pragma GCC optimize("no-trapping-math")
#include "tensor/fused/gelu_tanh.h"

#include <omp.h>

#include "tensor/cpu_features.h"
#include "tensor/fused/gelu_tanh_kernels.h"
#include "tensor/fused/kernel_util.h"

namespace t2m::fused {

namespace {

template <typename T>
void forward_chunk(T* out, const T* inp, int64_t n) {
  if (use_avx512_kernels()) return gelu_forward_chunk_avx512(out, inp, n);
  gelu_forward_chunk(out, inp, n);
}

template <typename T>
void backward_chunk(T* dinp, const T* dout, const T* inp, int64_t n) {
  if (use_avx512_kernels()) return gelu_backward_chunk_avx512(dinp, dout, inp, n);
  gelu_backward_chunk(dinp, dout, inp, n);
}

}  // namespace

template <typename T>
void gelu_tanh_forward(T* out, const T* inp, int64_t n) {
  check_dim("gelu_tanh_forward", "n", n, 0);
  if (n == 0) return;
  check_ptr("gelu_tanh_forward", "out", out);
  check_ptr("gelu_tanh_forward", "inp", inp);
  const int nt = fused_threads(n);
  if (nt == 1) return forward_chunk(out, inp, n);
#pragma omp parallel num_threads(nt)
  {
    const auto [i0, i1] = row_range(n, omp_get_thread_num(), omp_get_num_threads());
    forward_chunk(out + i0, inp + i0, i1 - i0);
  }
}

template <typename T>
void gelu_tanh_backward(T* dinp, const T* dout, const T* inp, int64_t n) {
  check_dim("gelu_tanh_backward", "n", n, 0);
  if (n == 0) return;
  check_ptr("gelu_tanh_backward", "dinp", dinp);
  check_ptr("gelu_tanh_backward", "dout", dout);
  check_ptr("gelu_tanh_backward", "inp", inp);
  const int nt = fused_threads(n);
  if (nt == 1) return backward_chunk(dinp, dout, inp, n);
#pragma omp parallel num_threads(nt)
  {
    const auto [i0, i1] = row_range(n, omp_get_thread_num(), omp_get_num_threads());
    backward_chunk(dinp + i0, dout + i0, inp + i0, i1 - i0);
  }
}

template void gelu_tanh_forward<float>(float*, const float*, int64_t);
template void gelu_tanh_forward<double>(double*, const double*, int64_t);
template void gelu_tanh_backward<float>(float*, const float*, const float*, int64_t);
template void gelu_tanh_backward<double>(double*, const double*, const double*, int64_t);

}  // namespace t2m::fused
