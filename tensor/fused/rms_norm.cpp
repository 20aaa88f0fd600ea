// rms_norm.cpp — dx = rstd * (dn - n * mean(dn * n)) with n = x * rstd and dn = dy * weight.
#include "tensor/fused/rms_norm.h"

#include <omp.h>

#include <cmath>
#include <cstring>

#include "tensor/fused/kernel_util.h"
#include "tensor/fused/scratch.h"

namespace t2m::fused {

template <typename T>
T rms_norm_row_forward(T* y, const T* x, const T* weight, int64_t C, T eps) {
  T ss = 0;
#pragma omp simd reduction(+ : ss)
  for (int64_t c = 0; c < C; ++c) ss += x[c] * x[c];
  const T r = (T)1 / std::sqrt(ss / (T)C + eps);
  if (weight) {
    for (int64_t c = 0; c < C; ++c) y[c] = x[c] * r * weight[c];
  } else {
    for (int64_t c = 0; c < C; ++c) y[c] = x[c] * r;
  }
  return r;
}

template <typename T>
void rms_norm_row_backward(T* dx, T* dweight, const T* dy, const T* x, const T* weight, T r, int64_t C) {
  T sum_dn_n = 0;
#pragma omp simd reduction(+ : sum_dn_n)
  for (int64_t c = 0; c < C; ++c) {
    const T dn = weight ? dy[c] * weight[c] : dy[c];
    sum_dn_n += dn * x[c] * r;
  }
  const T mdnn = sum_dn_n / (T)C;
  for (int64_t c = 0; c < C; ++c) {
    const T dn = weight ? dy[c] * weight[c] : dy[c];
    dx[c] = r * (dn - x[c] * r * mdnn);
  }
  if (dweight)
    for (int64_t c = 0; c < C; ++c) dweight[c] += dy[c] * x[c] * r;
}

template <typename T>
void rms_norm_forward(T* out, T* rstd, const T* inp, const T* weight, int64_t N, int64_t C, T eps) {
  const char* op = "rms_norm_forward";
  check_dim(op, "N", N, 0);
  check_dim(op, "C", C, 1);
  if (!(eps >= 0)) throw Error("rms_norm_forward: eps must be >= 0");
  if (N == 0) return;
  check_ptr(op, "out", out);
  check_ptr(op, "rstd", rstd);
  check_ptr(op, "inp", inp);
  const int nt = fused_threads(N * C);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t i = 0; i < N; ++i) rstd[i] = rms_norm_row_forward(out + i * C, inp + i * C, weight, C, eps);
}

template <typename T>
void rms_norm_backward(T* dinp, T* dweight, const T* dout, const T* inp, const T* weight, const T* rstd, int64_t N,
                       int64_t C) {
  const char* op = "rms_norm_backward";
  check_dim(op, "N", N, 0);
  check_dim(op, "C", C, 1);
  if (N == 0) return;
  check_ptr(op, "dinp", dinp);
  check_ptr(op, "dout", dout);
  check_ptr(op, "inp", inp);
  check_ptr(op, "rstd", rstd);
  const int nt = fused_threads(N * C);
  T* partial = dweight ? fused_scratch<T>(0, (int64_t)nt * C) : nullptr;
  if (partial) std::memset(partial, 0, sizeof(T) * nt * C);
#pragma omp parallel num_threads(nt) if (nt > 1)
  {
    const int tid = omp_get_thread_num();
    const auto [i0, i1] = row_range(N, tid, omp_get_num_threads());
    T* pw = partial ? partial + (int64_t)tid * C : nullptr;
    for (int64_t i = i0; i < i1; ++i)
      rms_norm_row_backward(dinp + i * C, pw, dout + i * C, inp + i * C, weight, rstd[i], C);
  }
  if (partial)
    for (int t = 0; t < nt; ++t)
      for (int64_t c = 0; c < C; ++c) dweight[c] += partial[(int64_t)t * C + c];
}

template float rms_norm_row_forward<float>(float*, const float*, const float*, int64_t, float);
template double rms_norm_row_forward<double>(double*, const double*, const double*, int64_t, double);
template void rms_norm_row_backward<float>(float*, float*, const float*, const float*, const float*, float, int64_t);
template void rms_norm_row_backward<double>(double*, double*, const double*, const double*, const double*, double,
                                            int64_t);
template void rms_norm_forward<float>(float*, float*, const float*, const float*, int64_t, int64_t, float);
template void rms_norm_forward<double>(double*, double*, const double*, const double*, int64_t, int64_t, double);
template void rms_norm_backward<float>(float*, float*, const float*, const float*, const float*, const float*,
                                       int64_t, int64_t);
template void rms_norm_backward<double>(double*, double*, const double*, const double*, const double*,
                                        const double*, int64_t, int64_t);

}  // namespace t2m::fused
