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
// Every head function takes row strides (HeadRows), so the same loops serve the (B, H, T, d) layout
// (small_forward_all / small_backward_all) and heads read and written in place in the projections' rows
// (small_heads_forward_all / small_heads_backward_all, attention_heads.h: q and k go through per-thread scratch for
// the QK-norm and RoPE).
#pragma once
#include <cmath>
#include <cstring>

#include <omp.h>

#include "tensor/fused/attention_heads.h"
#include "tensor/fused/attention_qk_rows.h"
#include "tensor/fused/attention_small.h"
#include "tensor/fused/fast_exp.h"
#include "tensor/fused/kernel_util.h"
#include "tensor/fused/scratch.h"

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
};

// Rows r < RB of out (row stride ldo, NV vectors wide) = scale * sum over g < ng, m < n_in (in that order) of
// w[r * wr + (g * n_in + m) * wm] X[g * xg + m * ldx]: X rows NV vectors wide (row stride ldx), in ng groups of n_in
// rows xg apart (one group unless said). RB x NV accumulators in registers, one FMA chain per element.
template <typename T, int NV, int RB>
inline void row_sums_block(T* out, int64_t ldo, const T* w, int64_t wr, int64_t wm, const T* X, int64_t ldx,
                           int64_t n_in, T scale, int64_t xg = 0, int64_t ng = 1) {
  using VT = Vec<T>;
  using V = typename VT::V;
  constexpr int L = VT::L;
  V acc[RB][NV];
#pragma GCC unroll 16
  for (int u = 0; u < RB; ++u)
#pragma GCC unroll 8
    for (int v = 0; v < NV; ++v) acc[u][v] = V{};
  for (int64_t g = 0; g < ng; ++g) {
    const T* Xg = X + g * xg;
    const T* wg = w + g * n_in * wm;
    for (int64_t m = 0; m < n_in; ++m) {
      V x[NV];
#pragma GCC unroll 8
      for (int v = 0; v < NV; ++v) x[v] = VT::load(Xg + m * ldx + v * L);
#pragma GCC unroll 16
      for (int u = 0; u < RB; ++u) {
        // A scalar times a vector: the compiler splats it straight from memory ({1toN} operand or a broadcast
        // load). Writing the splat as V{} + a costs a scalar add and a register broadcast per row, both on the
        // FMA ports of Intel cores (0 + a cannot be folded: it turns -0 into +0).
        const T a = wg[u * wr + m * wm];
#pragma GCC unroll 8
        for (int v = 0; v < NV; ++v) acc[u][v] += a * x[v];
      }
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

// xt (D x ldt) = x (n x D, row stride ldx) transposed, columns n..ldt-1 zero.
template <typename T, int D>
inline void transpose_padded(T* xt, int64_t ldt, const T* x, int64_t ldx, int64_t n) {
  for (int c = 0; c < D; ++c) {
    T* row = xt + c * ldt;
    for (int64_t j = 0; j < n; ++j) row[j] = x[j * ldx + c];
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

// out[j] = scale * dot(a, B_j) for rows B_j of B (n x d, row stride ldb), four rows per pass over a.
template <typename T>
inline void dots(T* out, const T* a, const T* B, int64_t ldb, int64_t n, int64_t d, T scale) {
  int64_t j = 0;
  for (; j + 4 <= n; j += 4) {
    const T *b0 = B + j * ldb, *b1 = b0 + ldb, *b2 = b1 + ldb, *b3 = b2 + ldb;
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
  for (; j < n; ++j) out[j] = dot(a, B + j * ldb, d) * scale;
}

template <typename T>
inline void axpy(T* y, T a, const T* x, int64_t d) {
#pragma omp simd
  for (int64_t c = 0; c < d; ++c) y[c] += a * x[c];
}

// out (D) = sum_r w[r * ws] X[r] over n rows X[r] (row stride ldx): the accumulator stays in registers when D is a
// compile-time constant (D = 0: run-time d, accumulated in out).
template <typename T, int D>
inline void wsum(T* out, const T* w, int64_t ws, const T* X, int64_t ldx, int64_t n, int64_t d) {
  if constexpr (D > 0) {
    T acc[D] = {};
    for (int64_t r = 0; r < n; ++r) {
      const T wr = w[r * ws];
      const T* xr = X + r * ldx;
#pragma omp simd
      for (int c = 0; c < D; ++c) acc[c] += wr * xr[c];
    }
#pragma omp simd
    for (int c = 0; c < D; ++c) out[c] = acc[c];
  } else {
    std::memset(out, 0, sizeof(T) * d);
    for (int64_t r = 0; r < n; ++r) axpy(out, w[r * ws], X + r * ldx, d);
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

// Where one head's rows are: row t of q at q + t * ldq, and so on. ld = d in the (B, H, T, d) layout; heads read
// and written in place in the projections' (B, T, W) rows (attention_heads.h) have ld = W. o is the output in the
// forward and dO in the backward.
template <typename T>
struct HeadRows {
  const T *q, *k, *v, *o;
  int64_t ldq, ldk, ldv, ldo;
};
// The gradients of a head (any pointer may be null) and their row strides.
template <typename T>
struct HeadGradRows {
  T *dq, *dk, *dv;
  int64_t ldq, ldk, ldv;
};

// One head: q (Tq,d), k/v (Tk,d), m (Tk) or null -> o (Tq,d; x.o is the same rows, read-only), p (Tq,Tk).
template <typename T, int D>
void head_forward(T* o, const HeadRows<T>& x, T* p, const T* m, int64_t Tq, int64_t Tk, int64_t d, bool causal,
                  T scale) {
  for (int64_t i = 0; i < Tq; ++i) {
    T* pr = p + i * Tk;
    const int64_t jend = causal ? i + 1 : Tk;  // keys [jend, Tk) are hidden by the causal mask
    dots(pr, x.q + i * x.ldq, x.k, x.ldk, jend, d, scale);
    if (!softmax_row(pr, pr, m, jend, Tk)) {
      std::memset(o + i * x.ldo, 0, sizeof(T) * d);
      continue;
    }
    wsum<T, D>(o + i * x.ldo, pr, 1, x.v, x.ldv, jend, d);  // o_i = sum_j p_ij v_j
  }
}

// One head's probabilities p (Tq,Tk) from its q/k rows: scaled dot products and the masked softmax of each row.
template <typename T>
void head_probs(const HeadRows<T>& x, T* p, const T* m, int64_t Tq, int64_t Tk, int64_t d, bool causal, T scale) {
  for (int64_t i = 0; i < Tq; ++i) {
    T* pr = p + i * Tk;
    const int64_t jend = causal ? i + 1 : Tk;
    dots(pr, x.q + i * x.ldq, x.k, x.ldk, jend, d, scale);
    softmax_row(pr, pr, m, jend, Tk);
  }
}

// From dP (Tq rows of ds, row stride Tk, overwritten with dS = p * (dP - rowsum(p * dP)) * scale) to dq (Tq,d) and
// dk (Tk,d) (either may be null).
template <typename T, int D>
void head_grads_from_dp(const HeadGradRows<T>& gr, const HeadRows<T>& x, const T* p, T* ds, int64_t Tq, int64_t Tk,
                        int64_t d, T scale) {
  for (int64_t i = 0; i < Tq; ++i) softmax_grad_row(ds + i * Tk, p + i * Tk, Tk, scale);
  if (gr.dq)  // dq_i = sum_j ds_ij k_j
    for (int64_t i = 0; i < Tq; ++i) wsum<T, D>(gr.dq + i * gr.ldq, ds + i * Tk, 1, x.k, x.ldk, Tk, d);
  if (gr.dk)  // dk_j = sum_i ds_ij q_i
    for (int64_t j = 0; j < Tk; ++j) wsum<T, D>(gr.dk + j * gr.ldk, ds + j, Tk, x.q, x.ldq, Tq, d);
}

// One head: dO = x.o (Tq,d), p (Tq,Tk) -> dq (Tq,d), dk/dv (Tk,d) (any may be null); ds: Tq*Tk scratch.
template <typename T, int D>
void head_backward(const HeadGradRows<T>& gr, const HeadRows<T>& x, const T* p, int64_t Tq, int64_t Tk, int64_t d,
                   T scale, T* ds) {
  if (gr.dv)  // dv_j = sum_i p_ij g_i
    for (int64_t j = 0; j < Tk; ++j) wsum<T, D>(gr.dv + j * gr.ldv, p + j, Tk, x.o, x.ldo, Tq, d);
  if (!gr.dq && !gr.dk) return;
  for (int64_t i = 0; i < Tq; ++i) dots(ds + i * Tk, x.o + i * x.ldo, x.v, x.ldv, Tk, d, (T)1);  // dP rows
  head_grads_from_dp<T, D>(gr, x, p, ds, Tq, Tk, d, scale);
}

// Scratch of one thread for the register-blocked path: scores or dS (Tq x tkp), and K or V transposed (D x tkp).
template <typename T>
struct HeadScratch {
  T scores[kSmallAttentionTile];
  T xt[kMaxBlockedHeadDim * kMaxScoreVectors * Vec<T>::L];
};

// The probabilities p (Tq,Tk) of a head served by the register-blocked path (tkp = padded_keys(Tq, Tk) > 0):
// S = scale Q K^T over the transposed keys, then the masked softmax of each row.
template <typename T, int D>
void head_probs_blocked(const HeadRows<T>& x, T* p, const T* m, int64_t Tq, int64_t Tk, int64_t tkp, bool causal,
                        T scale, HeadScratch<T>& sc) {
  constexpr int L = Vec<T>::L;
  transpose_padded<T, D>(sc.xt, tkp, x.k, x.ldk, Tk);
  row_sums_nv<T>(int(tkp / L), sc.scores, tkp, x.q, x.ldq, 1, sc.xt, tkp, Tq, D, scale);  // S = scale Q K^T
  for (int64_t i = 0; i < Tq; ++i) {
    T* pr = p + i * Tk;
    const T* sr = sc.scores + i * tkp;
    softmax_row(pr, sr, m, causal ? i + 1 : Tk, Tk);  // a row without visible keys gives p = 0, so o = 0
  }
}

// head_forward for a head served by the register-blocked path.
template <typename T, int D>
void head_forward_blocked(T* o, const HeadRows<T>& x, T* p, const T* m, int64_t Tq, int64_t Tk, int64_t tkp,
                          bool causal, T scale, HeadScratch<T>& sc) {
  constexpr int L = Vec<T>::L;
  head_probs_blocked<T, D>(x, p, m, Tq, Tk, tkp, causal, scale, sc);
  row_sums<T, D / L>(o, x.ldo, p, Tk, 1, x.v, x.ldv, Tq, Tk, (T)1);  // O = P V (hidden keys have p = 0)
}

// From dP (Tq rows of ds, row stride tkp, overwritten with dS) to dq and dk on the register-blocked path.
template <typename T, int D>
void head_grads_from_dp_blocked(const HeadGradRows<T>& gr, const HeadRows<T>& x, const T* p, T* ds, int64_t Tq,
                                int64_t Tk, int64_t tkp, T scale) {
  constexpr int L = Vec<T>::L;
  for (int64_t i = 0; i < Tq; ++i) softmax_grad_row(ds + i * tkp, p + i * Tk, Tk, scale);
  if (gr.dq) row_sums<T, D / L>(gr.dq, gr.ldq, ds, tkp, 1, x.k, x.ldk, Tq, Tk, (T)1);  // dQ = dS K
  if (gr.dk) row_sums<T, D / L>(gr.dk, gr.ldk, ds, 1, tkp, x.q, x.ldq, Tk, Tq, (T)1);  // dK = dS^T Q
}

// head_backward for a head served by the register-blocked path.
template <typename T, int D>
void head_backward_blocked(const HeadGradRows<T>& gr, const HeadRows<T>& x, const T* p, int64_t Tq, int64_t Tk,
                           int64_t tkp, T scale, HeadScratch<T>& sc) {
  constexpr int L = Vec<T>::L;
  if (gr.dv) row_sums<T, D / L>(gr.dv, gr.ldv, p, 1, Tk, x.o, x.ldo, Tk, Tq, (T)1);  // dV = P^T dO
  if (!gr.dq && !gr.dk) return;
  T* ds = sc.scores;
  transpose_padded<T, D>(sc.xt, tkp, x.v, x.ldv, Tk);
  row_sums_nv<T>(int(tkp / L), ds, tkp, x.o, x.ldo, 1, sc.xt, tkp, Tq, D, (T)1);  // dP = dO V^T
  head_grads_from_dp_blocked<T, D>(gr, x, p, ds, Tq, Tk, tkp, scale);
}

// One head on the register-blocked path when it serves it (tkp > 0), else on the dot/axpy loops.
template <typename T, int D>
void head_forward_any(T* o, const HeadRows<T>& x, T* p, const T* m, int64_t Tq, int64_t Tk, int64_t d, int64_t tkp,
                      bool causal, T scale, HeadScratch<T>& sc) {
  if constexpr (D > 0) {
    if (tkp > 0) return head_forward_blocked<T, D>(o, x, p, m, Tq, Tk, tkp, causal, scale, sc);
  }
  head_forward<T, D>(o, x, p, m, Tq, Tk, d, causal, scale);
}
template <typename T, int D>
void head_backward_any(const HeadGradRows<T>& gr, const HeadRows<T>& x, const T* p, int64_t Tq, int64_t Tk, int64_t d,
                       int64_t tkp, T scale, HeadScratch<T>& sc) {
  if constexpr (D > 0) {
    if (tkp > 0) return head_backward_blocked<T, D>(gr, x, p, Tq, Tk, tkp, scale, sc);
  }
  head_backward<T, D>(gr, x, p, Tq, Tk, d, scale, sc.scores);
}

// The probabilities alone (head_forward_any without O = P V), and the backward from a given dP: for callers whose
// values are not per-head rows (attention_ctx.h). dP is in ds with row stride ds_stride<T, D>(Tk, tkp).
template <typename T, int D>
void head_probs_any(const HeadRows<T>& x, T* p, const T* m, int64_t Tq, int64_t Tk, int64_t d, int64_t tkp,
                    bool causal, T scale, HeadScratch<T>& sc) {
  if constexpr (D > 0) {
    if (tkp > 0) return head_probs_blocked<T, D>(x, p, m, Tq, Tk, tkp, causal, scale, sc);
  }
  head_probs(x, p, m, Tq, Tk, d, causal, scale);
}
template <typename T, int D>
constexpr int64_t ds_stride(int64_t Tk, int64_t tkp) {
  return D > 0 && tkp > 0 ? tkp : Tk;
}
template <typename T, int D>
void head_grads_from_dp_any(const HeadGradRows<T>& gr, const HeadRows<T>& x, const T* p, T* ds, int64_t Tq,
                            int64_t Tk, int64_t d, int64_t tkp, T scale) {
  if constexpr (D > 0) {
    if (tkp > 0) return head_grads_from_dp_blocked<T, D>(gr, x, p, ds, Tq, Tk, tkp, scale);
  }
  head_grads_from_dp<T, D>(gr, x, p, ds, Tq, Tk, d, scale);
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
        const HeadRows<T> x{q + bh * Tq * d, k + bh * Tk * d, v + bh * Tk * d, o, d, d, d, d};
        const T* m = key_mask ? key_mask + (bh / s.H) * Tk : nullptr;
        head_forward_any<T, D>(o, x, p, m, Tq, Tk, d, tkp, s.causal, scale, sc);
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
        const HeadGradRows<T> gr{dq ? dq + bh * Tq * d : nullptr, dk ? dk + bh * Tk * d : nullptr,
                                 dv ? dv + bh * Tk * d : nullptr, d, d, d};
        const HeadRows<T> x{q ? q + bh * Tq * d : nullptr, k ? k + bh * Tk * d : nullptr,
                            v ? v + bh * Tk * d : nullptr, dout + bh * Tq * d, d, d, d, d};
        const T* p = att + bh * Tq * Tk;
        head_backward_any<T, D>(gr, x, p, Tq, Tk, d, tkp, scale, sc);
      }
    }
  });
}

// Head bh's q and k as the attention sees them (attention_heads.h): through the QK-norm and RoPE into the scratch qs
// ((Tq + Tk) x d; their rstd written where rstd_q / rstd_k are not null), and x pointed there.
template <typename T>
inline void head_qk_to_scratch(HeadRows<T>& x, T* qs, const AttentionHeads<T>& a, int64_t bh, T* rstd_q, T* rstd_k) {
  const int64_t Tq = a.s.Tq, Tk = a.s.Tk, d = a.s.d;
  T* ks = qs + Tq * d;
  qk_rows_forward(qs, x.q, x.ldq, Tq, d, a.q_norm, a.norm_eps, rstd_q ? rstd_q + bh * Tq : nullptr, a.cos_tab,
                  a.sin_tab);
  qk_rows_forward(ks, x.k, x.ldk, Tk, d, a.k_norm, a.norm_eps, rstd_k ? rstd_k + bh * Tk : nullptr, a.cos_tab,
                  a.sin_tab);
  x.q = qs, x.k = ks, x.ldq = x.ldk = d;
}

// The backward of head_qk_to_scratch: the gradients gr.dq / gr.dk (rows of the scratch gs, either null: not needed)
// into dq / dk rows at qx / kx's head (null: only the norm-weight partials pq / pk), through RoPE and the QK-norm.
template <typename T>
inline void head_qk_from_scratch(T* dq, int64_t lddq, T* dk, int64_t lddk, T* pq, T* pk, const HeadGradRows<T>& gr,
                                 T* gs, const T* qx, const T* kx, const AttentionHeads<T>& a, int64_t bh,
                                 const T* rstd_q, const T* rstd_k) {
  const int64_t Tq = a.s.Tq, Tk = a.s.Tk, d = a.s.d;
  const bool norm = a.q_norm != nullptr;
  T* spare = gs + (Tq + Tk) * d;
  if (gr.dq)
    qk_rows_backward(dq, lddq, pq, gr.dq, qx, a.ldq, Tq, d, a.q_norm, norm ? rstd_q + bh * Tq : nullptr, a.cos_tab,
                     a.sin_tab, spare);
  if (gr.dk)
    qk_rows_backward(dk, lddk, pk, gr.dk, kx, a.ldk, Tk, d, a.k_norm, norm ? rstd_k + bh * Tk : nullptr, a.cos_tab,
                     a.sin_tab, spare);
}

// attention_heads_forward (attention_heads.h): heads split over threads whole, as small_forward_all.
template <typename T>
void small_heads_forward_all(T* out, int64_t ldo, T* att, T* rstd_q, T* rstd_k, const AttentionHeads<T>& a) {
  const AttentionShape& s = a.s;
  const int64_t H = s.H, BH = s.B * s.H, Tq = s.Tq, Tk = s.Tk, d = s.d;
  const bool through_scratch = a.q_norm || a.cos_tab;  // q and k are transformed before the attention
  const T scale = (T)(1.0 / std::sqrt((double)d));
  const int nt = fused_threads(BH * Tq * Tk * d);
  with_head_dim(d, [&]<int D>() {
    const int64_t tkp = padded_keys<T, D>(Tq, Tk);
#pragma omp parallel num_threads(nt) if (nt > 1)
    {
      HeadScratch<T> sc;
      T* qs = through_scratch ? fused_scratch<T>(3, (Tq + Tk) * d) : nullptr;
#pragma omp for schedule(static)
      for (int64_t bh = 0; bh < BH; ++bh) {
        const int64_t b = bh / H, h = bh % H;
        T* o = out + b * Tq * ldo + h * d;
        T* p = att + bh * Tq * Tk;
        HeadRows<T> x{a.q + b * Tq * a.ldq + h * d, a.k + b * Tk * a.ldk + h * d, a.v + b * Tk * a.ldv + h * d, o,
                      a.ldq, a.ldk, a.ldv, ldo};
        if (through_scratch) head_qk_to_scratch(x, qs, a, bh, rstd_q, rstd_k);
        const T* m = a.key_mask ? a.key_mask + b * Tk : nullptr;
        head_forward_any<T, D>(o, x, p, m, Tq, Tk, d, tkp, s.causal, scale, sc);
      }
    }
  });
}

// attention_heads_backward: thread u takes the contiguous heads row_range(BH, u, nt), so its norm-weight partial
// sums the rows rms_norm_backward's thread u would (for an even split), in the same order.
template <typename T>
void small_heads_backward_all(T* dq, int64_t lddq, T* dk, int64_t lddk, T* dv, int64_t lddv, T* dq_norm,
                              T* dk_norm, const T* dout, int64_t ldg, const T* att, const T* rstd_q,
                              const T* rstd_k, const AttentionHeads<T>& a) {
  const AttentionShape& s = a.s;
  const int64_t H = s.H, BH = s.B * s.H, Tq = s.Tq, Tk = s.Tk, d = s.d;
  const bool norm = a.q_norm != nullptr, through_scratch = norm || a.cos_tab;
  const bool need_dq = dq || (norm && dq_norm), need_dk = dk || (norm && dk_norm);
  const T scale = (T)(1.0 / std::sqrt((double)d));
  const int nt = fused_threads(BH * Tq * Tk * d);
  T* partial = norm && (dq_norm || dk_norm) ? fused_scratch<T>(0, (int64_t)nt * 2 * d) : nullptr;  // [u][q | k]
  if (partial) std::memset(partial, 0, sizeof(T) * nt * 2 * d);
  with_head_dim(d, [&]<int D>() {
    const int64_t tkp = padded_keys<T, D>(Tq, Tk);
#pragma omp parallel num_threads(nt) if (nt > 1)
    {
      const int u = omp_get_thread_num();
      const auto [h0, h1] = row_range(BH, u, omp_get_num_threads());
      HeadScratch<T> sc;
      T* qs = through_scratch ? fused_scratch<T>(3, (Tq + Tk) * d) : nullptr;  // q, k as the attention saw them
      T* gs = through_scratch ? fused_scratch<T>(4, (Tq + Tk + 1) * d) : nullptr;  // their gradients, a spare row
      T* pq = partial && dq_norm ? partial + (int64_t)u * 2 * d : nullptr;
      T* pk = partial && dk_norm ? partial + (int64_t)u * 2 * d + d : nullptr;
      for (int64_t bh = h0; bh < h1; ++bh) {
        const int64_t b = bh / H, h = bh % H;
        const T* qx = a.q + b * Tq * a.ldq + h * d;
        const T* kx = a.k + b * Tk * a.ldk + h * d;
        T* dqh = dq ? dq + b * Tq * lddq + h * d : nullptr;
        T* dkh = dk ? dk + b * Tk * lddk + h * d : nullptr;
        HeadRows<T> x{qx, kx, a.v + b * Tk * a.ldv + h * d, dout + b * Tq * ldg + h * d, a.ldq, a.ldk, a.ldv, ldg};
        HeadGradRows<T> gr{dqh, dkh, dv ? dv + b * Tk * lddv + h * d : nullptr, lddq, lddk, lddv};
        if (through_scratch) {
          head_qk_to_scratch(x, qs, a, bh, (T*)nullptr, (T*)nullptr);
          gr.dq = need_dq ? gs : nullptr, gr.dk = need_dk ? gs + Tq * d : nullptr, gr.ldq = gr.ldk = d;
        }
        const T* p = att + bh * Tq * Tk;
        head_backward_any<T, D>(gr, x, p, Tq, Tk, d, tkp, scale, sc);
        if (through_scratch) head_qk_from_scratch(dqh, lddq, dkh, lddk, pq, pk, gr, gs, qx, kx, a, bh, rstd_q, rstd_k);
      }
    }
  });
  for (int u = 0; partial && u < nt; ++u)
    for (int64_t c = 0; c < d; ++c) {
      if (dq_norm) dq_norm[c] += partial[(int64_t)u * 2 * d + c];
      if (dk_norm) dk_norm[c] += partial[(int64_t)u * 2 * d + d + c];
    }
}

}  // namespace
}  // namespace t2m::fused
