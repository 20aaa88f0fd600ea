// softmax.cpp — row-wise, one pass for the max, one for exp and sum, one to scale.
// exp_approx's clamps vectorise only without -ftrapping-math; nothing here reads floating-point exception flags.
#pragma GCC optimize("no-trapping-math")
#include "tensor/fused/softmax.h"

#include <cmath>

#include "tensor/fused/fast_exp.h"
#include "tensor/fused/kernel_util.h"

namespace t2m::fused {

namespace {

void check_rows(const char* op, int64_t N, int64_t C, const void* a, const void* b) {
  check_dim(op, "N", N, 0);
  check_dim(op, "C", C, 1);
  if (N == 0) return;
  check_ptr(op, "output", a);
  check_ptr(op, "input", b);
}

}  // namespace

template <typename T>
void softmax_forward(T* out, const T* inp, int64_t N, int64_t C) {
  check_rows("softmax_forward", N, C, out, inp);
  const int nt = fused_threads(N * C);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t i = 0; i < N; ++i) {
    const T* x = inp + i * C;
    T* y = out + i * C;
    T mx = x[0];
    for (int64_t c = 1; c < C; ++c) mx = x[c] > mx ? x[c] : mx;
    for (int64_t c = 0; c < C; ++c) y[c] = fexp(x[c] - mx);
    T s = 0;
#pragma omp simd reduction(+ : s)
    for (int64_t c = 0; c < C; ++c) s += y[c];
    const T inv = (T)1 / s;
    for (int64_t c = 0; c < C; ++c) y[c] *= inv;
  }
}

template <typename T>
void softmax_backward(T* dinp, const T* dout, const T* out, int64_t N, int64_t C) {
  check_rows("softmax_backward", N, C, dinp, dout);
  if (N > 0) check_ptr("softmax_backward", "out", out);
  const int nt = fused_threads(N * C);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t i = 0; i < N; ++i) {
    const T* dy = dout + i * C;
    const T* y = out + i * C;
    T* dx = dinp + i * C;
    T s = 0;
#pragma omp simd reduction(+ : s)
    for (int64_t c = 0; c < C; ++c) s += dy[c] * y[c];
    for (int64_t c = 0; c < C; ++c) dx[c] = y[c] * (dy[c] - s);
  }
}

template <typename T>
void log_softmax_forward(T* out, const T* inp, int64_t N, int64_t C) {
  check_rows("log_softmax_forward", N, C, out, inp);
  const int nt = fused_threads(N * C);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t i = 0; i < N; ++i) {
    const T* x = inp + i * C;
    T* y = out + i * C;
    T mx = x[0];
    for (int64_t c = 1; c < C; ++c) mx = x[c] > mx ? x[c] : mx;
    T s = 0;
#pragma omp simd reduction(+ : s)
    for (int64_t c = 0; c < C; ++c) s += fexp(x[c] - mx);
    const T lse = mx + std::log(s);
    for (int64_t c = 0; c < C; ++c) y[c] = x[c] - lse;
  }
}

template <typename T>
void log_softmax_backward(T* dinp, const T* dout, const T* out, int64_t N, int64_t C) {
  check_rows("log_softmax_backward", N, C, dinp, dout);
  if (N > 0) check_ptr("log_softmax_backward", "out", out);
  const int nt = fused_threads(N * C);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t i = 0; i < N; ++i) {
    const T* dy = dout + i * C;
    const T* y = out + i * C;
    T* dx = dinp + i * C;
    T s = 0;
#pragma omp simd reduction(+ : s)
    for (int64_t c = 0; c < C; ++c) s += dy[c];
    for (int64_t c = 0; c < C; ++c) dx[c] = dy[c] - fexp(y[c]) * s;
  }
}

template void softmax_forward<float>(float*, const float*, int64_t, int64_t);
template void softmax_forward<double>(double*, const double*, int64_t, int64_t);
template void softmax_backward<float>(float*, const float*, const float*, int64_t, int64_t);
template void softmax_backward<double>(double*, const double*, const double*, int64_t, int64_t);
template void log_softmax_forward<float>(float*, const float*, int64_t, int64_t);
template void log_softmax_forward<double>(double*, const double*, int64_t, int64_t);
template void log_softmax_backward<float>(float*, const float*, const float*, int64_t, int64_t);
template void log_softmax_backward<double>(double*, const double*, const double*, int64_t, int64_t);

}  // namespace t2m::fused
