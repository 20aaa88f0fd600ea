// group_norm.cpp — one (batch, group) block of Cg*T contiguous elements per work item; backward
// dx = rstd * (dn - mean(dn) - n * mean(dn * n)) over the block, dn = dy * weight[c].
#include "tensor/fused/group_norm.h"

#include <omp.h>

#include <cmath>
#include <cstring>
#include <string>

#include "tensor/fused/kernel_util.h"
#include "tensor/fused/row_stats.h"
#include "tensor/fused/scratch.h"

namespace t2m::fused {

namespace {

// Channel c's affine output y = x w + b, w = weight[c] rstd, b = bias[c] - mean w (one FMA each): how the forward
// writes it, and how the ReLU backward recomputes its sign (the same operations, so the same bits).
template <typename T>
struct ChannelAffine {
  T w, b;
  T operator()(T x) const { return std::fma(x, w, b); }
};
template <typename T>
ChannelAffine<T> channel_affine(const T* weight, const T* bias, int64_t c, T m, T r) {
  const T w = weight ? weight[c] * r : r;
  return {w, std::fma(-m, w, bias ? bias[c] : (T)0)};
}

void check_groups(const char* op, int64_t B, int64_t C, int64_t Tlen, int64_t G) {
  check_dim(op, "B", B, 0);
  check_dim(op, "C", C, 1);
  check_dim(op, "T", Tlen, 1);
  check_dim(op, "G", G, 1);
  if (C % G != 0)
    throw Error(std::string(op) + ": C=" + std::to_string(C) + " is not divisible by G=" + std::to_string(G));
}

}  // namespace

template <typename T>
void group_norm_forward(T* out, T* mean, T* rstd, const T* inp, const T* weight, const T* bias, int64_t B,
                        int64_t C, int64_t Tlen, int64_t G, T eps, bool relu) {
  const char* op = "group_norm_forward";
  check_groups(op, B, C, Tlen, G);
  if (!(eps >= 0)) throw Error("group_norm_forward: eps must be >= 0");
  if (B == 0) return;
  check_ptr(op, "out", out);
  check_ptr(op, "mean", mean);
  check_ptr(op, "rstd", rstd);
  check_ptr(op, "inp", inp);
  const int64_t Cg = C / G, n = Cg * Tlen;
  const int nt = fused_threads(B * C * Tlen);
#pragma omp parallel num_threads(nt) if (nt > 1)
  {
    const auto [j0, j1] = row_range(B * G, omp_get_thread_num(), omp_get_num_threads());
    for (int64_t bg = j0; bg < j1;) {
      // Up to four (sample, group) blocks' statistics side by side (row_stats.h).
      const T* xs[4];
      T m4[4], r4[4];
      const int blocks = row_group_stats(inp, n, bg, j1, n, eps, xs, m4, r4);
      for (int j = 0; j < blocks; ++j, ++bg) {
        const int64_t g = bg % G;
        const T* x = xs[j];
        T* y = out + bg * n;
        const T m = m4[j], r = r4[j];
        mean[bg] = m;
        rstd[bg] = r;
        for (int64_t cc = 0; cc < Cg; ++cc) {
          const ChannelAffine<T> a = channel_affine(weight, bias, g * Cg + cc, m, r);
          const T* xc = x + cc * Tlen;
          T* yc = y + cc * Tlen;
          if (relu)
            for (int64_t t = 0; t < Tlen; ++t) {
              const T yt = a(xc[t]);
              yc[t] = yt > (T)0 ? yt : (T)0;
            }
          else
            for (int64_t t = 0; t < Tlen; ++t) yc[t] = a(xc[t]);
        }
      }
    }
  }
}

template <typename T>
void group_norm_backward(T* dinp, T* dweight, T* dbias, const T* dout, const T* inp, const T* weight,
                         const T* mean, const T* rstd, int64_t B, int64_t C, int64_t Tlen, int64_t G,
                         bool relu, const T* bias) {
  const char* op = "group_norm_backward";
  check_groups(op, B, C, Tlen, G);
  if (B == 0) return;
  check_ptr(op, "dinp", dinp);
  check_ptr(op, "dout", dout);
  check_ptr(op, "inp", inp);
  check_ptr(op, "mean", mean);
  check_ptr(op, "rstd", rstd);
  const int64_t Cg = C / G, n = Cg * Tlen;
  const int nt = fused_threads(B * C * Tlen);
  const bool want_params = dweight || dbias;
  T* partial = want_params ? fused_scratch<T>(0, (int64_t)nt * 2 * C) : nullptr;
  if (partial) std::memset(partial, 0, sizeof(T) * nt * 2 * C);
#pragma omp parallel num_threads(nt) if (nt > 1)
  {
    const int tid = omp_get_thread_num();
    const auto [j0, j1] = row_range(B * G, tid, omp_get_num_threads());
    T* pw = partial ? partial + (int64_t)tid * 2 * C : nullptr;
    T* pb = pw ? pw + C : nullptr;
    for (int64_t bg = j0; bg < j1; ++bg) {
      const int64_t g = bg % G;
      const T* x = inp + bg * n;
      const T* dy = dout + bg * n;
      T* dx = dinp + bg * n;
      const T m = mean[bg], r = rstd[bg];
      T sum_dn = 0, sum_dn_n = 0;
      for (int64_t cc = 0; cc < Cg; ++cc) {
        const int64_t c = g * Cg + cc;
        const T w = weight ? weight[c] : (T)1;
        const T* xc = x + cc * Tlen;
        const T* dyc = dy + cc * Tlen;
        T s_dy = 0, s_dy_n = 0;
        if (relu) {
          const ChannelAffine<T> a = channel_affine(weight, bias, c, m, r);
#pragma omp simd reduction(+ : s_dy, s_dy_n)
          for (int64_t t = 0; t < Tlen; ++t) {
            const T g = dyc[t];  // read unconditionally: a blend, not a masked load (slow on AMD)
            const T nn = (xc[t] - m) * r, d = a(xc[t]) > (T)0 ? g : (T)0;
            s_dy += d;
            s_dy_n += d * nn;
          }
        } else {
#pragma omp simd reduction(+ : s_dy, s_dy_n)
          for (int64_t t = 0; t < Tlen; ++t) {
            const T nn = (xc[t] - m) * r;
            s_dy += dyc[t];
            s_dy_n += dyc[t] * nn;
          }
        }
        sum_dn += w * s_dy;
        sum_dn_n += w * s_dy_n;
        if (pw) {
          pw[c] += s_dy_n;
          pb[c] += s_dy;
        }
      }
      const T mdn = sum_dn / (T)n, mdnn = sum_dn_n / (T)n;
      for (int64_t cc = 0; cc < Cg; ++cc) {
        const int64_t c = g * Cg + cc;
        const T w = weight ? weight[c] : (T)1;
        const T* xc = x + cc * Tlen;
        const T* dyc = dy + cc * Tlen;
        T* dxc = dx + cc * Tlen;
        if (relu) {
          const ChannelAffine<T> a = channel_affine(weight, bias, c, m, r);
          for (int64_t t = 0; t < Tlen; ++t) {
            const T g = dyc[t];
            const T nn = (xc[t] - m) * r, d = a(xc[t]) > (T)0 ? g : (T)0;
            dxc[t] = r * (w * d - mdn - nn * mdnn);
          }
        } else {
          for (int64_t t = 0; t < Tlen; ++t) {
            const T nn = (xc[t] - m) * r;
            dxc[t] = r * (w * dyc[t] - mdn - nn * mdnn);
          }
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

template void group_norm_forward<float>(float*, float*, float*, const float*, const float*, const float*, int64_t,
                                        int64_t, int64_t, int64_t, float, bool);
template void group_norm_forward<double>(double*, double*, double*, const double*, const double*, const double*,
                                         int64_t, int64_t, int64_t, int64_t, double, bool);
template void group_norm_backward<float>(float*, float*, float*, const float*, const float*, const float*,
                                         const float*, const float*, int64_t, int64_t, int64_t, int64_t, bool,
                                         const float*);
template void group_norm_backward<double>(double*, double*, double*, const double*, const double*, const double*,
                                          const double*, const double*, int64_t, int64_t, int64_t, int64_t, bool,
                                          const double*);

}  // namespace t2m::fused
