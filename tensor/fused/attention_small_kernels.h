// attention_small_kernels.h — INTERNAL to tensor/fused/attention_small*.cpp: the per-head loops of the small-head
// attention path, included by attention_small.cpp (baseline AVX2 build) and attention_small_avx512.cpp (compiled
// with AVX-512 flags). Everything is in an anonymous namespace, so each including file gets its own copy compiled
// for its own ISA (no ODR merging of differently compiled inline functions).
// Forward per head: S = scale Q K^T (dot products, 4 keys at a time), masked max-subtracted softmax, O = P V.
// Backward per head: dV = P^T dO, dP = dO V^T, dS = P * (dP - rowsum(P * dP)) * scale (whole head), dQ = dS K,
// dK = dS^T Q. Every output row is one weighted row sum (wsum) whose accumulator stays in registers for the head
// dims 32/64/96/128 (compile-time D); other head dims run the same sums with a memory accumulator.
#pragma once
#include <cmath>
#include <cstring>

#include "tensor/fused/attention_small.h"
#include "tensor/fused/fast_exp.h"
#include "tensor/fused/kernel_util.h"

namespace t2m::fused {
namespace {

template <typename T>
inline T dot(const T* a, const T* b, int64_t d) {
  T s = 0;
#pragma omp simd reduction(+ : s)
  for (int64_t c = 0; c < d; ++c) s += a[c] * b[c];
  return s;
}

// out[j] = scale * dot(a, B_j) for rows B_j of B (n x d, row stride d), four rows per pass over a.
template <typename T>
inline void dots(T* out, const T* a, const T* B, int64_t n, int64_t d, T scale) {
  int64_t j = 0;
  for (; j + 4 <= n; j += 4) {
    const T *b0 = B + j * d, *b1 = b0 + d, *b2 = b1 + d, *b3 = b2 + d;
    T s0 = 0, s1 = 0, s2 = 0, s3 = 0;
#pragma omp simd reduction(+ : s0, s1, s2, s3)
    for (int64_t c = 0; c < d; ++c) {
      s0 += a[c] * b0[c];
      s1 += a[c] * b1[c];
      s2 += a[c] * b2[c];
      s3 += a[c] * b3[c];
    }
    out[j] = s0 * scale, out[j + 1] = s1 * scale, out[j + 2] = s2 * scale, out[j + 3] = s3 * scale;
  }
  for (; j < n; ++j) out[j] = dot(a, B + j * d, d) * scale;
}

template <typename T>
inline void axpy(T* y, T a, const T* x, int64_t d) {
#pragma omp simd
  for (int64_t c = 0; c < d; ++c) y[c] += a * x[c];
}

// out (D) = sum_r w[r * ws] X[r] over n rows X[r] (row stride D): the accumulator stays in registers when D is a
// compile-time constant (D = 0: run-time d, accumulated in out).
template <typename T, int D>
inline void wsum(T* out, const T* w, int64_t ws, const T* X, int64_t n, int64_t d) {
  if constexpr (D > 0) {
    T acc[D] = {};
    for (int64_t r = 0; r < n; ++r) {
      const T wr = w[r * ws];
      const T* xr = X + r * D;
#pragma omp simd
      for (int c = 0; c < D; ++c) acc[c] += wr * xr[c];
    }
#pragma omp simd
    for (int c = 0; c < D; ++c) out[c] = acc[c];
  } else {
    std::memset(out, 0, sizeof(T) * d);
    for (int64_t r = 0; r < n; ++r) axpy(out, w[r * ws], X + r * d, d);
  }
}

// One head: q (Tq,d), k/v (Tk,d), m (Tk) or null -> o (Tq,d), p (Tq,Tk).
template <typename T, int D>
void head_forward(T* o, T* p, const T* q, const T* k, const T* v, const T* m, int64_t Tq, int64_t Tk, int64_t d,
                  bool causal, T scale) {
  for (int64_t i = 0; i < Tq; ++i) {
    T* pr = p + i * Tk;
    const int64_t jend = causal ? i + 1 : Tk;  // keys [jend, Tk) are hidden by the causal mask
    dots(pr, q + i * d, k, jend, d, scale);
    T mx = 0;
    bool any = false;
    for (int64_t j = 0; j < jend; ++j) {
      if (m && m[j] == (T)0) continue;
      if (!any || pr[j] > mx) mx = pr[j];
      any = true;
    }
    if (!any) {
      for (int64_t j = 0; j < Tk; ++j) pr[j] = 0;
      std::memset(o + i * d, 0, sizeof(T) * d);
      continue;
    }
    for (int64_t j = 0; j < jend; ++j) pr[j] = fexp(pr[j] - mx);
    if (m)
      for (int64_t j = 0; j < jend; ++j)
        if (m[j] == (T)0) pr[j] = 0;
    for (int64_t j = jend; j < Tk; ++j) pr[j] = 0;
    T sum = 0;
    for (int64_t j = 0; j < jend; ++j) sum += pr[j];
    const T inv = (T)1 / sum;
    for (int64_t j = 0; j < jend; ++j) pr[j] *= inv;
    wsum<T, D>(o + i * d, pr, 1, v, jend, d);  // o_i = sum_j p_ij v_j
  }
}

// One head: g (Tq,d), p (Tq,Tk) -> dq (Tq,d), dk/dv (Tk,d) (any may be null); ds: Tq*Tk scratch.
template <typename T, int D>
void head_backward(T* dq, T* dk, T* dv, const T* g, const T* p, const T* q, const T* k, const T* v, int64_t Tq,
                   int64_t Tk, int64_t d, T scale, T* ds) {
  if (dv)
    for (int64_t j = 0; j < Tk; ++j) wsum<T, D>(dv + j * d, p + j, Tk, g, Tq, d);  // dv_j = sum_i p_ij g_i
  if (!dq && !dk) return;
  for (int64_t i = 0; i < Tq; ++i) {
    const T* pr = p + i * Tk;
    T* dr = ds + i * Tk;
    dots(dr, g + i * d, v, Tk, d, (T)1);  // dP row
    T rs = 0;
    for (int64_t j = 0; j < Tk; ++j) rs += pr[j] * dr[j];
    for (int64_t j = 0; j < Tk; ++j) dr[j] = pr[j] * (dr[j] - rs) * scale;
  }
  if (dq)
    for (int64_t i = 0; i < Tq; ++i) wsum<T, D>(dq + i * d, ds + i * Tk, 1, k, Tk, d);  // dq_i = sum_j ds_ij k_j
  if (dk)
    for (int64_t j = 0; j < Tk; ++j) wsum<T, D>(dk + j * d, ds + j, Tk, q, Tq, d);  // dk_j = sum_i ds_ij q_i
}

// Calls f.template operator()<D>() with D the compile-time head dim for the common sizes, else D = 0.
template <typename F>
inline void with_head_dim(int64_t d, F&& f) {
  switch (d) {
    case 32: f.template operator()<32>(); break;
    case 64: f.template operator()<64>(); break;
    case 96: f.template operator()<96>(); break;
    case 128: f.template operator()<128>(); break;
    default: f.template operator()<0>(); break;
  }
}

template <typename T>
void small_forward_all(T* out, T* att, const T* q, const T* k, const T* v, const T* key_mask,
                       const AttentionShape& s) {
  const int64_t BH = s.B * s.H, Tq = s.Tq, Tk = s.Tk, d = s.d;
  const T scale = (T)(1.0 / std::sqrt((double)d));
  const int nt = fused_threads(BH * Tq * Tk * d);
  with_head_dim(d, [&]<int D>() {
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
    for (int64_t bh = 0; bh < BH; ++bh)
      head_forward<T, D>(out + bh * Tq * d, att + bh * Tq * Tk, q + bh * Tq * d, k + bh * Tk * d, v + bh * Tk * d,
                         key_mask ? key_mask + (bh / s.H) * Tk : nullptr, Tq, Tk, d, s.causal, scale);
  });
}

template <typename T>
void small_backward_all(T* dq, T* dk, T* dv, const T* dout, const T* att, const T* q, const T* k, const T* v,
                        const AttentionShape& s) {
  const int64_t BH = s.B * s.H, Tq = s.Tq, Tk = s.Tk, d = s.d;
  const T scale = (T)(1.0 / std::sqrt((double)d));
  const int nt = fused_threads(BH * Tq * Tk * d);
  with_head_dim(d, [&]<int D>() {
#pragma omp parallel num_threads(nt) if (nt > 1)
    {
      T ds[kSmallAttentionTile];  // dS of one head (Tq * Tk <= kSmallAttentionTile)
#pragma omp for schedule(static)
      for (int64_t bh = 0; bh < BH; ++bh)
        head_backward<T, D>(dq ? dq + bh * Tq * d : nullptr, dk ? dk + bh * Tk * d : nullptr,
                            dv ? dv + bh * Tk * d : nullptr, dout + bh * Tq * d, att + bh * Tq * Tk,
                            q ? q + bh * Tq * d : nullptr, k ? k + bh * Tk * d : nullptr,
                            v ? v + bh * Tk * d : nullptr, Tq, Tk, d, scale, ds);
    }
  });
}

}  // namespace
}  // namespace t2m::fused
