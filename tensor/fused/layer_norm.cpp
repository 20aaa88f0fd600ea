// layer_norm.cpp — two-pass statistics per row; backward in the standard fused form
// dx = rstd * (dn - mean(dn) - n * mean(dn * n)) with n the normalised input and dn = dy * weight.
#include "tensor/fused/layer_norm.h"

#include <omp.h>

#include <cmath>
#include <cstring>

#include "tensor/fused/kernel_util.h"
#include "tensor/fused/row_stats.h"
#include "tensor/fused/scratch.h"

namespace t2m::fused {

template <typename T>
void layer_norm_forward(T* out, T* mean, T* rstd, const T* inp, const T* weight, const T* bias, int64_t N,
                        int64_t C, T eps) {
  const char* op = "layer_norm_forward";
  check_dim(op, "N", N, 0);
  check_dim(op, "C", C, 1);
  if (!(eps >= 0)) throw Error("layer_norm_forward: eps must be >= 0");
  if (N == 0) return;
  check_ptr(op, "out", out);
  check_ptr(op, "mean", mean);
  check_ptr(op, "rstd", rstd);
  check_ptr(op, "inp", inp);
  const int nt = fused_threads(N * C);
#pragma omp parallel num_threads(nt) if (nt > 1)
  {
    const auto [i0, i1] = row_range(N, omp_get_thread_num(), omp_get_num_threads());
    for (int64_t i = i0; i < i1;) {
      const T* x[4];
      T m4[4], r4[4];
      const int rows = row_group_stats(inp, C, i, i1, C, eps, x, m4, r4);
      for (int j = 0; j < rows; ++j, ++i) {
        const T* xr = x[j];
        T* y = out + i * C;
        const T m = m4[j], r = r4[j];
        mean[i] = m;
        rstd[i] = r;
        if (weight && bias) {
          for (int64_t c = 0; c < C; ++c) y[c] = (xr[c] - m) * r * weight[c] + bias[c];
        } else if (weight) {
          for (int64_t c = 0; c < C; ++c) y[c] = (xr[c] - m) * r * weight[c];
        } else if (bias) {
          for (int64_t c = 0; c < C; ++c) y[c] = (xr[c] - m) * r + bias[c];
        } else {
          for (int64_t c = 0; c < C; ++c) y[c] = (xr[c] - m) * r;
        }
      }
    }
  }
}

template <typename T>
void layer_norm_backward(T* dinp, T* dweight, T* dbias, const T* dout, const T* inp, const T* weight,
                         const T* mean, const T* rstd, int64_t N, int64_t C, const T* tanh_out) {
  const char* op = "layer_norm_backward";
  check_dim(op, "N", N, 0);
  check_dim(op, "C", C, 1);
  if (N == 0) return;
  check_ptr(op, "dinp", dinp);
  check_ptr(op, "dout", dout);
  check_ptr(op, "inp", inp);
  check_ptr(op, "mean", mean);
  check_ptr(op, "rstd", rstd);
  const int nt = fused_threads(N * C);
  const bool want_params = dweight || dbias;
  T* partial = want_params ? fused_scratch<T>(0, (int64_t)nt * 2 * C) : nullptr;
  if (partial) std::memset(partial, 0, sizeof(T) * nt * 2 * C);
#pragma omp parallel num_threads(nt) if (nt > 1)
  {
    const int tid = omp_get_thread_num();
    const auto [i0, i1] = row_range(N, tid, omp_get_num_threads());
    T* pw = partial ? partial + (int64_t)tid * 2 * C : nullptr;
    T* pb = pw ? pw + C : nullptr;
    T* dt = tanh_out ? fused_scratch<T>(1, C) : nullptr;  // this row's gradient before the tanh
    for (int64_t i = i0; i < i1; ++i) {
      const T* x = inp + i * C;
      const T* dy = dout + i * C;
      if (dt) {
        const T* y = tanh_out + i * C;
#pragma omp simd
        for (int64_t c = 0; c < C; ++c) dt[c] = dy[c] * ((T)1 - y[c] * y[c]);
        dy = dt;
      }
      T* dx = dinp + i * C;
      const T m = mean[i], r = rstd[i];
      // The weight test is outside the loops: with it inside, GCC vectorised only the affine version of the sums
      // (the plain LayerNorm of adaLN ran a scalar reduction).
      T sum_dn = 0, sum_dn_n = 0;
      if (weight) {
#pragma omp simd reduction(+ : sum_dn, sum_dn_n)
        for (int64_t c = 0; c < C; ++c) {
          const T dn = dy[c] * weight[c];
          sum_dn += dn;
          sum_dn_n += dn * ((x[c] - m) * r);
        }
      } else {
#pragma omp simd reduction(+ : sum_dn, sum_dn_n)
        for (int64_t c = 0; c < C; ++c) {
          sum_dn += dy[c];
          sum_dn_n += dy[c] * ((x[c] - m) * r);
        }
      }
      const T mdn = sum_dn / (T)C, mdnn = sum_dn_n / (T)C;
      if (weight) {
#pragma omp simd
        for (int64_t c = 0; c < C; ++c) dx[c] = r * (dy[c] * weight[c] - mdn - (x[c] - m) * r * mdnn);
      } else {
#pragma omp simd
        for (int64_t c = 0; c < C; ++c) dx[c] = r * (dy[c] - mdn - (x[c] - m) * r * mdnn);
      }
      if (pw) {
        for (int64_t c = 0; c < C; ++c) {
          pw[c] += dy[c] * (x[c] - m) * r;
          pb[c] += dy[c];
        }
      }
    }
  }
  if (partial) {
    for (int t = 0; t < nt; ++t) {
      const T* pw = partial + (int64_t)t * 2 * C;
      if (dweight)
        for (int64_t c = 0; c < C; ++c) dweight[c] += pw[c];
      if (dbias)
        for (int64_t c = 0; c < C; ++c) dbias[c] += pw[C + c];
    }
  }
}

template void layer_norm_forward<float>(float*, float*, float*, const float*, const float*, const float*, int64_t,
                                        int64_t, float);
template void layer_norm_forward<double>(double*, double*, double*, const double*, const double*, const double*,
                                         int64_t, int64_t, double);
template void layer_norm_backward<float>(float*, float*, float*, const float*, const float*, const float*,
                                         const float*, const float*, int64_t, int64_t, const float*);
template void layer_norm_backward<double>(double*, double*, double*, const double*, const double*, const double*,
                                          const double*, const double*, int64_t, int64_t, const double*);

}  // namespace t2m::fused
