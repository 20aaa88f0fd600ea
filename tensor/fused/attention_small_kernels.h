// attention_small_kernels.h — INTERNAL to tensor/fused/attention_small*.cpp: the per-head loops of the small-head
// attention path, included by attention_small.cpp (baseline AVX2 build) and attention_small_avx512.cpp (compiled
// with AVX-512 flags). Everything is in an anonymous namespace, so each including file gets its own copy compiled
// for its own ISA (no ODR merging of differently compiled inline functions).
// Forward per head: S = scale Q K^T (dot products, 4 keys at a time), masked max-subtracted softmax, O = P V.
// Backward per head: dV = P^T dO, dP = dO V^T, dS = P * (dP - rowsum(P * dP)) * scale (whole head), dQ = dS K,
// dK = dS^T Q. For the head dims 32/64/96/128 (compile-time D) every product is a register-blocked row sum
// (row_sums: a block of output rows, one vector accumulator per row and lane group, an FMA chain over the inner
// index); the score and dP products read a transposed copy of K or V (D x Tk, zero padded to whole vectors) so that
// they are row sums too. Other head dims, and heads too wide for the padded scratch, run dot products and axpys.
#pragma once
#include <cmath>
#include <cstring>

#include "tensor/fused/attention_small.h"
#include "tensor/fused/fast_exp.h"
#include "tensor/fused/kernel_util.h"

namespace t2m::fused {
namespace {

// The vector type of the build (zmm in attention_small_avx512.cpp, ymm in the baseline build): GCC vector
// extensions, so one source serves float and double and both ISAs.
#if defined(__AVX512F__)
constexpr int kVecBytes = 64;
#else
constexpr int kVecBytes = 32;
#endif
template <typename T>
struct Vec {
  typedef T V __attribute__((vector_size(kVecBytes)));
  static constexpr int L = kVecBytes / int(sizeof(T));  // lanes
  static V load(const T* p) {
    V v;
    std::memcpy(&v, p, sizeof v);
    return v;
  }
  static void store(T* p, V v) { std::memcpy(p, &v, sizeof v); }
  static V set1(T x) { return V{} + x; }
};

// Rows r < RB of out (row stride ldo, NV vectors wide) = scale * sum_{m < n_in} w[r * wr + m * wm] X[m] (X rows NV
// vectors wide, row stride ldx): RB x NV accumulators in registers, one FMA chain per element in m order.
template <typename T, int NV, int RB>
inline void row_sums_block(T* out, int64_t ldo, const T* w, int64_t wr, int64_t wm, const T* X, int64_t ldx,
                           int64_t n_in, T scale) {
  using VT = Vec<T>;
  using V = typename VT::V;
  constexpr int L = VT::L;
  V acc[RB][NV];
#pragma GCC unroll 16
  for (int u = 0; u < RB; ++u)
#pragma GCC unroll 8
    for (int v = 0; v < NV; ++v) acc[u][v] = V{};
  for (int64_t m = 0; m < n_in; ++m) {
    V x[NV];
#pragma GCC unroll 8
    for (int v = 0; v < NV; ++v) x[v] = VT::load(X + m * ldx + v * L);
#pragma GCC unroll 16
    for (int u = 0; u < RB; ++u) {
      const V a = VT::set1(w[u * wr + m * wm]);
#pragma GCC unroll 8
      for (int v = 0; v < NV; ++v) acc[u][v] += a * x[v];
    }
  }
#pragma GCC unroll 16
  for (int u = 0; u < RB; ++u)
#pragma GCC unroll 8
    for (int v = 0; v < NV; ++v) VT::store(out + u * ldo + v * L, acc[u][v] * scale);
}

// All n_out rows of the product above, in blocks of as many rows as keep ~16 accumulators in registers.
template <typename T, int NV>
inline void row_sums(T* out, int64_t ldo, const T* w, int64_t wr, int64_t wm, const T* X, int64_t ldx,
                     int64_t n_out, int64_t n_in, T scale) {
  constexpr int RB = NV >= 16 ? 1 : NV >= 4 ? 16 / NV : 8;
  int64_t r = 0;
  for (; r + RB <= n_out; r += RB)
    row_sums_block<T, NV, RB>(out + r * ldo, ldo, w + r * wr, wr, wm, X, ldx, n_in, scale);
  for (; r < n_out; ++r) row_sums_block<T, NV, 1>(out + r * ldo, ldo, w + r * wr, wr, wm, X, ldx, n_in, scale);
}

// row_sums with a run-time width of nv vectors (1..4): the scores and dP, Tk lanes wide.
template <typename T>
inline void row_sums_nv(int nv, T* out, int64_t ldo, const T* w, int64_t wr, int64_t wm, const T* X, int64_t ldx,
                        int64_t n_out, int64_t n_in, T scale) {
  switch (nv) {
    case 1: return row_sums<T, 1>(out, ldo, w, wr, wm, X, ldx, n_out, n_in, scale);
    case 2: return row_sums<T, 2>(out, ldo, w, wr, wm, X, ldx, n_out, n_in, scale);
    case 3: return row_sums<T, 3>(out, ldo, w, wr, wm, X, ldx, n_out, n_in, scale);
    default: return row_sums<T, 4>(out, ldo, w, wr, wm, X, ldx, n_out, n_in, scale);
  }
}

// xt (D x ldt) = x (n x D) transposed, columns n..ldt-1 zero.
template <typename T, int D>
inline void transpose_padded(T* xt, int64_t ldt, const T* x, int64_t n) {
  for (int c = 0; c < D; ++c) {
    T* row = xt + c * ldt;
    for (int64_t j = 0; j < n; ++j) row[j] = x[j * D + c];
    for (int64_t j = n; j < ldt; ++j) row[j] = 0;
  }
}

// The register-blocked path serves a head when D is a compile-time multiple of the vector width and the padded
// score rows (Tk rounded up to whole vectors, at most 4) fit the per-thread scratch. The largest compile-time head
// dim (with_head_dim below) sizes the transposed K/V scratch.
constexpr int64_t kMaxScoreVectors = 4;
constexpr int kMaxBlockedHeadDim = 128;
template <typename T, int D>
inline int64_t padded_keys(int64_t Tq, int64_t Tk) {  // 0: not served
  constexpr int L = Vec<T>::L;
  if constexpr (D == 0 || D % L != 0 || D > kMaxBlockedHeadDim) {
    return 0;
  } else {
    const int64_t tkp = (Tk + L - 1) / L * L;
    return tkp / L <= kMaxScoreVectors && Tq * tkp <= kSmallAttentionTile ? tkp : 0;
  }
}

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

// One row of the masked softmax: p[j] (j < Tk) from the scores s (may be p itself) of the keys j < jend with m[j]
// != 0 (m null: all); the other p[j] are 0. False, and p all 0, when no key is visible.
template <typename T>
inline bool softmax_row(T* p, const T* s, const T* m, int64_t jend, int64_t Tk) {
  T mx = 0;
  bool any = false;
  for (int64_t j = 0; j < jend; ++j) {
    if (m && m[j] == (T)0) continue;
    if (!any || s[j] > mx) mx = s[j];
    any = true;
  }
  if (!any) {
    for (int64_t j = 0; j < Tk; ++j) p[j] = 0;
    return false;
  }
  for (int64_t j = 0; j < jend; ++j) p[j] = m && m[j] == (T)0 ? (T)0 : fexp(s[j] - mx);
  for (int64_t j = jend; j < Tk; ++j) p[j] = 0;
  T sum = 0;
  for (int64_t j = 0; j < jend; ++j) sum += p[j];
  const T inv = (T)1 / sum;
  for (int64_t j = 0; j < jend; ++j) p[j] *= inv;
  return true;
}

// The softmax backward of one row, in place: dP row d (Tk) -> dS = p * (d - sum_j p_j d_j) * scale.
template <typename T>
inline void softmax_grad_row(T* d, const T* p, int64_t Tk, T scale) {
  T rs = 0;
  for (int64_t j = 0; j < Tk; ++j) rs += p[j] * d[j];
  for (int64_t j = 0; j < Tk; ++j) d[j] = p[j] * (d[j] - rs) * scale;
}

// One head: q (Tq,d), k/v (Tk,d), m (Tk) or null -> o (Tq,d), p (Tq,Tk).
template <typename T, int D>
void head_forward(T* o, T* p, const T* q, const T* k, const T* v, const T* m, int64_t Tq, int64_t Tk, int64_t d,
                  bool causal, T scale) {
  for (int64_t i = 0; i < Tq; ++i) {
    T* pr = p + i * Tk;
    const int64_t jend = causal ? i + 1 : Tk;  // keys [jend, Tk) are hidden by the causal mask
    dots(pr, q + i * d, k, jend, d, scale);
    if (!softmax_row(pr, pr, m, jend, Tk)) {
      std::memset(o + i * d, 0, sizeof(T) * d);
      continue;
    }
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
    T* dr = ds + i * Tk;
    dots(dr, g + i * d, v, Tk, d, (T)1);  // dP row
    softmax_grad_row(dr, p + i * Tk, Tk, scale);
  }
  if (dq)
    for (int64_t i = 0; i < Tq; ++i) wsum<T, D>(dq + i * d, ds + i * Tk, 1, k, Tk, d);  // dq_i = sum_j ds_ij k_j
  if (dk)
    for (int64_t j = 0; j < Tk; ++j) wsum<T, D>(dk + j * d, ds + j, Tk, q, Tq, d);  // dk_j = sum_i ds_ij q_i
}

// Scratch of one thread for the register-blocked path: scores or dS (Tq x tkp), and K or V transposed (D x tkp).
template <typename T>
struct HeadScratch {
  T scores[kSmallAttentionTile];
  T xt[kMaxBlockedHeadDim * kMaxScoreVectors * Vec<T>::L];
};

// head_forward for a head served by the register-blocked path (tkp = padded_keys(Tq, Tk) > 0).
template <typename T, int D>
void head_forward_blocked(T* o, T* p, const T* q, const T* k, const T* v, const T* m, int64_t Tq, int64_t Tk,
                          int64_t tkp, bool causal, T scale, HeadScratch<T>& sc) {
  constexpr int L = Vec<T>::L;
  transpose_padded<T, D>(sc.xt, tkp, k, Tk);
  row_sums_nv<T>(int(tkp / L), sc.scores, tkp, q, D, 1, sc.xt, tkp, Tq, D, scale);  // S = scale Q K^T
  for (int64_t i = 0; i < Tq; ++i) {
    T* pr = p + i * Tk;
    const T* sr = sc.scores + i * tkp;
    softmax_row(pr, sr, m, causal ? i + 1 : Tk, Tk);  // a row without visible keys gives p = 0, so o = 0
  }
  row_sums<T, D / L>(o, D, p, Tk, 1, v, D, Tq, Tk, (T)1);  // O = P V (hidden keys have p = 0)
}

// head_backward for a head served by the register-blocked path.
template <typename T, int D>
void head_backward_blocked(T* dq, T* dk, T* dv, const T* g, const T* p, const T* q, const T* k, const T* v,
                           int64_t Tq, int64_t Tk, int64_t tkp, T scale, HeadScratch<T>& sc) {
  constexpr int L = Vec<T>::L;
  if (dv) row_sums<T, D / L>(dv, D, p, 1, Tk, g, D, Tk, Tq, (T)1);  // dV = P^T dO
  if (!dq && !dk) return;
  T* ds = sc.scores;
  transpose_padded<T, D>(sc.xt, tkp, v, Tk);
  row_sums_nv<T>(int(tkp / L), ds, tkp, g, D, 1, sc.xt, tkp, Tq, D, (T)1);  // dP = dO V^T
  for (int64_t i = 0; i < Tq; ++i) softmax_grad_row(ds + i * tkp, p + i * Tk, Tk, scale);
  if (dq) row_sums<T, D / L>(dq, D, ds, tkp, 1, k, D, Tq, Tk, (T)1);  // dQ = dS K
  if (dk) row_sums<T, D / L>(dk, D, ds, 1, tkp, q, D, Tk, Tq, (T)1);  // dK = dS^T Q
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
    const int64_t tkp = padded_keys<T, D>(Tq, Tk);
#pragma omp parallel num_threads(nt) if (nt > 1)
    {
      HeadScratch<T> sc;
#pragma omp for schedule(static)
      for (int64_t bh = 0; bh < BH; ++bh) {
        T* o = out + bh * Tq * d;
        T* p = att + bh * Tq * Tk;
        const T *qh = q + bh * Tq * d, *kh = k + bh * Tk * d, *vh = v + bh * Tk * d;
        const T* m = key_mask ? key_mask + (bh / s.H) * Tk : nullptr;
        if constexpr (D > 0) {
          if (tkp > 0) {
            head_forward_blocked<T, D>(o, p, qh, kh, vh, m, Tq, Tk, tkp, s.causal, scale, sc);
            continue;
          }
        }
        head_forward<T, D>(o, p, qh, kh, vh, m, Tq, Tk, d, s.causal, scale);
      }
    }
  });
}

template <typename T>
void small_backward_all(T* dq, T* dk, T* dv, const T* dout, const T* att, const T* q, const T* k, const T* v,
                        const AttentionShape& s) {
  const int64_t BH = s.B * s.H, Tq = s.Tq, Tk = s.Tk, d = s.d;
  const T scale = (T)(1.0 / std::sqrt((double)d));
  const int nt = fused_threads(BH * Tq * Tk * d);
  with_head_dim(d, [&]<int D>() {
    const int64_t tkp = padded_keys<T, D>(Tq, Tk);
#pragma omp parallel num_threads(nt) if (nt > 1)
    {
      HeadScratch<T> sc;  // scores: dS of one head (Tq * Tk <= kSmallAttentionTile)
#pragma omp for schedule(static)
      for (int64_t bh = 0; bh < BH; ++bh) {
        T* dqh = dq ? dq + bh * Tq * d : nullptr;
        T* dkh = dk ? dk + bh * Tk * d : nullptr;
        T* dvh = dv ? dv + bh * Tk * d : nullptr;
        const T *g = dout + bh * Tq * d, *p = att + bh * Tq * Tk;
        const T* qh = q ? q + bh * Tq * d : nullptr;
        const T* kh = k ? k + bh * Tk * d : nullptr;
        const T* vh = v ? v + bh * Tk * d : nullptr;
        if constexpr (D > 0) {
          if (tkp > 0) {
            head_backward_blocked<T, D>(dqh, dkh, dvh, g, p, qh, kh, vh, Tq, Tk, tkp, scale, sc);
            continue;
          }
        }
        head_backward<T, D>(dqh, dkh, dvh, g, p, qh, kh, vh, Tq, Tk, d, scale, sc.scores);
      }
    }
  });
}

}  // namespace
}  // namespace t2m::fused
