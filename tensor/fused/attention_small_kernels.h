// attention_small_kernels.h — INTERNAL to tensor/fused/attention_small*.cpp: the per-head loops of the small-head
// attention path, included by attention_small.cpp (baseline AVX2 build) and attention_small_avx512.cpp (compiled
// with AVX-512 flags). Everything is in an anonymous namespace, so each including file gets its own copy compiled
// for its own ISA (no ODR merging of differently compiled inline functions).
// Forward per head: S = scale Q K^T (dot products, 4 keys at a time), masked max-subtracted softmax, O = P V
// (axpys). Backward per head: dV = P^T dO, dP = dO V^T, dS = P * (dP - rowsum(P * dP)) * scale, dQ = dS K,
// dK = dS^T Q.
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

// One head: q (Tq,d), k/v (Tk,d), m (Tk) or null -> o (Tq,d), p (Tq,Tk).
template <typename T>
void head_forward(T* o, T* p, const T* q, const T* k, const T* v, const T* m, int64_t Tq, int64_t Tk, int64_t d,
                  bool causal, T scale) {
  for (int64_t i = 0; i < Tq; ++i) {
    T* pr = p + i * Tk;
    T* orow = o + i * d;
    std::memset(orow, 0, sizeof(T) * d);
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
    for (int64_t j = 0; j < jend; ++j) {
      pr[j] *= inv;
      if (pr[j] != (T)0) axpy(orow, pr[j], v + j * d, d);
    }
  }
}

// One head: g (Tq,d), p (Tq,Tk) -> dq (Tq,d), dk/dv (Tk,d) (any may be null); ds: Tk scratch.
template <typename T>
void head_backward(T* dq, T* dk, T* dv, const T* g, const T* p, const T* q, const T* k, const T* v, int64_t Tq,
                   int64_t Tk, int64_t d, T scale, T* ds) {
  if (dv) std::memset(dv, 0, sizeof(T) * Tk * d);
  if (dq) std::memset(dq, 0, sizeof(T) * Tq * d);
  if (dk) std::memset(dk, 0, sizeof(T) * Tk * d);
  for (int64_t i = 0; i < Tq; ++i) {
    const T* pr = p + i * Tk;
    const T* gi = g + i * d;
    if (dv)
      for (int64_t j = 0; j < Tk; ++j)
        if (pr[j] != (T)0) axpy(dv + j * d, pr[j], gi, d);
    if (!dq && !dk) continue;
    dots(ds, gi, v, Tk, d, (T)1);  // dP row
    T rs = 0;
    for (int64_t j = 0; j < Tk; ++j) rs += pr[j] * ds[j];
    for (int64_t j = 0; j < Tk; ++j) ds[j] = pr[j] * (ds[j] - rs) * scale;
    for (int64_t j = 0; j < Tk; ++j) {
      if (ds[j] == (T)0) continue;
      if (dq) axpy(dq + i * d, ds[j], k + j * d, d);
      if (dk) axpy(dk + j * d, ds[j], q + i * d, d);
    }
  }
}


template <typename T>
void small_forward_all(T* out, T* att, const T* q, const T* k, const T* v, const T* key_mask,
                       const AttentionShape& s) {
  const int64_t BH = s.B * s.H, Tq = s.Tq, Tk = s.Tk, d = s.d;
  const T scale = (T)(1.0 / std::sqrt((double)d));
  const int nt = fused_threads(BH * Tq * Tk * d);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t bh = 0; bh < BH; ++bh)
    head_forward(out + bh * Tq * d, att + bh * Tq * Tk, q + bh * Tq * d, k + bh * Tk * d, v + bh * Tk * d,
                 key_mask ? key_mask + (bh / s.H) * Tk : nullptr, Tq, Tk, d, s.causal, scale);
}

template <typename T>
void small_backward_all(T* dq, T* dk, T* dv, const T* dout, const T* att, const T* q, const T* k, const T* v,
                        const AttentionShape& s) {
  const int64_t BH = s.B * s.H, Tq = s.Tq, Tk = s.Tk, d = s.d;
  const T scale = (T)(1.0 / std::sqrt((double)d));
  const int nt = fused_threads(BH * Tq * Tk * d);
#pragma omp parallel num_threads(nt) if (nt > 1)
  {
    T ds[kSmallAttentionTile];  // one row of dS (Tk <= kSmallAttentionTile)
#pragma omp for schedule(static)
    for (int64_t bh = 0; bh < BH; ++bh)
      head_backward(dq ? dq + bh * Tq * d : nullptr, dk ? dk + bh * Tk * d : nullptr, dv ? dv + bh * Tk * d : nullptr,
                    dout + bh * Tq * d, att + bh * Tq * Tk, q ? q + bh * Tq * d : nullptr,
                    k ? k + bh * Tk * d : nullptr, v ? v + bh * Tk * d : nullptr, Tq, Tk, d, scale, ds);
  }
}

}  // namespace
}  // namespace t2m::fused
