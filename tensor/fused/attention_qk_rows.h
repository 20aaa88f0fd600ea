// attention_qk_rows.h — INTERNAL to the attention kernels (attention_small_kernels.h and what includes it): one
// head's q or k rows as the attention sees them, through the QK RMS-norm and RoPE, and the backward of that. In an
// anonymous namespace like the kernels that include it, so each including file compiles its own copy for its ISA.
#pragma once
#include <cstdint>
#include <cstring>

#include "tensor/fused/rms_norm.h"
#include "tensor/fused/rope.h"

namespace t2m::fused {
namespace {

// Rows ahead whose cache lines the q / k row loops prefetch: one head's rows sit a whole projection row apart (D to
// 3 D floats), a stride the hardware prefetchers did not follow, and the norm's first loads missed (fm-paper B32
// Tm16: the forward row norm 0.80 -> ~0.6 % of the step's perf samples, its backward 0.45 -> 0.34 %).
constexpr int64_t kQkRowsAhead = 2;

// Prefetches row t + kQkRowsAhead of x (n rows, row stride ldx, d wide), when there is one.
template <typename T>
inline void prefetch_row_ahead(const T* x, int64_t ldx, int64_t t, int64_t n, int64_t d) {
  if (t + kQkRowsAhead >= n) return;
  const char* row = reinterpret_cast<const char*>(x + (t + kQkRowsAhead) * ldx);
  for (int64_t l = 0; l < d * int64_t(sizeof(T)); l += 64) __builtin_prefetch(row + l);
}

// q or k of one head as the attention sees it (attention_heads.h): n rows x (row stride ldx) -> y (n x d), RMS-norm
// with weight w (rstd written to r when not null) and RoPE when the tables are given, else a copy.
template <typename T>
inline void qk_rows_forward(T* y, const T* x, int64_t ldx, int64_t n, int64_t d, const T* w, T eps, T* r,
                            const T* cos_tab, const T* sin_tab) {
  const int64_t h = d / 2;
  for (int64_t t = 0; t < n; ++t) {
    T* yt = y + t * d;
    prefetch_row_ahead(x, ldx, t, n, d);
    if (w) {
      const T rt = rms_norm_row_forward(yt, x + t * ldx, w, d, eps);
      if (r) r[t] = rt;
    } else {
      std::memcpy(yt, x + t * ldx, sizeof(T) * d);
    }
    if (cos_tab) rope_rotate_row(yt, yt, cos_tab + t * h, sin_tab + t * h, h, (T)1);
  }
}

// The backward of qk_rows_forward: g (n x d, the gradient of y; overwritten) -> dx rows (row stride ldd; null: only
// the weight gradient, through the spare row) and the weight gradient accumulated into pw (may be null).
template <typename T>
inline void qk_rows_backward(T* dx, int64_t ldd, T* pw, T* g, const T* x, int64_t ldx, int64_t n, int64_t d,
                             const T* w, const T* rstd, const T* cos_tab, const T* sin_tab, T* spare) {
  const int64_t h = d / 2;
  for (int64_t t = 0; t < n; ++t) {
    T* gt = g + t * d;
    if (w) prefetch_row_ahead(x, ldx, t, n, d);
    if (cos_tab) rope_rotate_row(gt, gt, cos_tab + t * h, sin_tab + t * h, h, (T)-1);
    if (w)
      rms_norm_row_backward(dx ? dx + t * ldd : spare, pw, gt, x + t * ldx, w, rstd[t], d);
    else
      std::memcpy(dx + t * ldd, gt, sizeof(T) * d);
  }
}

}  // namespace
}  // namespace t2m::fused
