// gelu_tanh.cpp — with u = s (x + a x^3), t = tanh(u): dy/dx = 0.5 (1 + t) + 0.5 x (1 - t^2) s (1 + 3 a x^2).
// Comparisons in the clamps of exp_approx may not be if-converted (vectorised) under the default -ftrapping-math;
// no kernel here reads the floating-point exception flags, so trapping semantics are dropped for this file.
#pragma GCC optimize("no-trapping-math")
#include "tensor/fused/gelu_tanh.h"

#include <omp.h>

#include "tensor/fused/fast_exp.h"
#include "tensor/fused/kernel_util.h"

namespace t2m::fused {

namespace {
constexpr double kSqrt2OverPi = 0.79788456080286535588;
constexpr double kGeluA = 0.044715;

// One thread's contiguous chunk; a plain loop (no OpenMP construct) so that the float version vectorises.
template <typename T>
void gelu_forward_chunk(T* out, const T* inp, int64_t n) {
  const T s = (T)kSqrt2OverPi, a = (T)kGeluA;
#pragma omp simd
  for (int64_t i = 0; i < n; ++i) {
    const T x = inp[i];
    const T t = ftanh(s * (x + a * x * x * x));
    out[i] = (T)0.5 * x * ((T)1 + t);
  }
}

template <typename T>
void gelu_backward_chunk(T* dinp, const T* dout, const T* inp, int64_t n) {
  const T s = (T)kSqrt2OverPi, a = (T)kGeluA;
#pragma omp simd
  for (int64_t i = 0; i < n; ++i) {
    const T x = inp[i];
    const T x2 = x * x;
    const T t = ftanh(s * (x + a * x2 * x));
    const T d = (T)0.5 * ((T)1 + t) + (T)0.5 * x * ((T)1 - t * t) * s * ((T)1 + (T)3 * a * x2);
    dinp[i] = dout[i] * d;
  }
}

}  // namespace

template <typename T>
void gelu_tanh_forward(T* out, const T* inp, int64_t n) {
  check_dim("gelu_tanh_forward", "n", n, 0);
  if (n == 0) return;
  check_ptr("gelu_tanh_forward", "out", out);
  check_ptr("gelu_tanh_forward", "inp", inp);
  const int nt = fused_threads(n);
  if (nt == 1) return gelu_forward_chunk(out, inp, n);
#pragma omp parallel num_threads(nt)
  {
    const auto [i0, i1] = row_range(n, omp_get_thread_num(), omp_get_num_threads());
    gelu_forward_chunk(out + i0, inp + i0, i1 - i0);
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
  if (nt == 1) return gelu_backward_chunk(dinp, dout, inp, n);
#pragma omp parallel num_threads(nt)
  {
    const auto [i0, i1] = row_range(n, omp_get_thread_num(), omp_get_num_threads());
    gelu_backward_chunk(dinp + i0, dout + i0, inp + i0, i1 - i0);
  }
}

template void gelu_tanh_forward<float>(float*, const float*, int64_t);
template void gelu_tanh_forward<double>(double*, const double*, int64_t);
template void gelu_tanh_backward<float>(float*, const float*, const float*, int64_t);
template void gelu_tanh_backward<double>(double*, const double*, const double*, int64_t);

}  // namespace t2m::fused
