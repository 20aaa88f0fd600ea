// attention_ctx_kernels.h — INTERNAL to tensor/fused/attention_ctx*.cpp: the loops of attention_ctx.h, included by
// attention_ctx.cpp (baseline AVX2 build) and attention_ctx_avx512.cpp (AVX-512 flags); anonymous namespace, so each
// file gets its own copy for its own ISA (as attention_small_kernels.h, whose per-head pieces it reuses).
// Forward: per head P (head_probs_any); then per batch row b and block of columns U = P ctx_b for all heads
// (wide_row_sums: each two-vector chunk of the context rows copied to an L1 buffer, then every head's rows against
// it); ctx_values_all repeats the second part from the saved P.
// Backward per batch row b: per head dP = dU ctx_b^T (dot products of length C, register-blocked), the softmax and
// QK-norm backward (head_grads_from_dp_any, qk_rows_backward); then dctx_b = sum over (h, t) of P[h, t, :]^T dU[h, t]
// in one pass (wide_row_sums over the heads' rows).
#pragma once
#include <algorithm>
#include <cstring>

#include "tensor/fused/attention_ctx.h"
#include "tensor/fused/attention_small_kernels.h"

namespace t2m::fused {
namespace {

// The grouped row sum of row_sums_block (attention_small_kernels.h) for one column of n_out rows (the columns past
// the last whole vector).
template <typename T>
inline void wide_column(T* out, int64_t ldo, const T* w, int64_t wr, int64_t wm, const T* X, int64_t ldx, int64_t xg,
                        int64_t ni, int64_t ng, int64_t n_out) {
  for (int64_t u = 0; u < n_out; ++u) {
    T s = 0;
    for (int64_t g = 0; g < ng; ++g)
      for (int64_t i = 0; i < ni; ++i) s += w[u * wr + (g * ni + i) * wm] * X[g * xg + i * ldx];
    out[u * ldo] = s;
  }
}

// Accumulators of a wide_row_sums block: 8 rows x 2 vectors in the 32 zmm registers, 4 x 2 in the 16 ymm registers.
constexpr int kWideRows = kVecBytes == 64 ? 8 : 4;
// Up to this many X rows, a chunk's columns of them are copied to a contiguous buffer (16 KB with zmm) before the
// row blocks read them: X rows C floats apart (4 KB at C = 1024) all map to the same few L1 sets, and read in place
// they miss L1 on every step (U = P ctx ran at ~45 % of the FMA peak on the Intel host that way).
constexpr int64_t kStageRows = 128;

// Output rows of wide_row_sums in groups: rows [g * rows, (g + 1) * rows) are written from out + g * stride (one
// group of all rows unless said), so the heads of one batch row (u's (H, B, Tq, C) layout) go in one call.
struct RowGroups {
  int64_t rows = 0, stride = 0;
};

// All n_out rows and `width` columns of row_sums_block's grouped sum (scale 1): column chunks of two vectors (then
// one, then single columns), each chunk's X rows staged (kStageRows) and every row group's rows in blocks of
// kWideRows (then single rows) against them. Staging copies values, so the sums are the same either way.
template <typename T>
void wide_row_sums(T* out, int64_t ldo, const T* w, int64_t wr, int64_t wm, const T* X, int64_t ldx, int64_t xg,
                   int64_t ni, int64_t ng, int64_t n_out, int64_t width, RowGroups og = {}) {
  constexpr int L = Vec<T>::L;
  if (og.rows <= 0) og = {n_out, 0};
  auto group_out = [&](int64_t r0, int64_t c) { return out + r0 / og.rows * og.stride + c; };  // group of row r0
  const bool stage = ni * ng <= kStageRows;
  alignas(64) T buf[kStageRows * 2 * L];
  auto chunk = [&]<int NV>(int64_t c) {
    const T* xc = X + c;
    int64_t ldc = ldx, xgc = xg;
    if (stage) {
      // Each row's piece of the chunk after next is requested while this one is computed: the rows are C floats apart
      // (a page each at C = 1024), too many streams for the hardware prefetchers, and the copy stalled on every row.
      const bool ahead = c + 3 * NV * L <= width;
      for (int64_t g = 0; g < ng; ++g)
        for (int64_t i = 0; i < ni; ++i) {
          const T* row = X + g * xg + i * ldx + c;
          std::memcpy(buf + (g * ni + i) * NV * L, row, sizeof(T) * NV * L);
          if (ahead)
            for (int v = 0; v < NV; ++v) __builtin_prefetch(row + (2 * NV + v) * L);
        }
      xc = buf, ldc = NV * L, xgc = ni * NV * L;
    }
    for (int64_t r0 = 0; r0 < n_out; r0 += og.rows) {
      T* o = group_out(r0, c);
      const T* wg = w + r0 * wr;
      const int64_t rows = std::min(og.rows, n_out - r0);
      int64_t r = 0;
      for (; r + kWideRows <= rows; r += kWideRows)
        row_sums_block<T, NV, kWideRows>(o + r * ldo, ldo, wg + r * wr, wr, wm, xc, ldc, ni, (T)1, xgc, ng);
      for (; r < rows; ++r) row_sums_block<T, NV, 1>(o + r * ldo, ldo, wg + r * wr, wr, wm, xc, ldc, ni, (T)1, xgc, ng);
    }
  };
  int64_t c = 0;
  for (; c + 2 * L <= width; c += 2 * L) chunk.template operator()<2>(c);
  for (; c + L <= width; c += L) chunk.template operator()<1>(c);
  for (; c < width; ++c)
    for (int64_t r0 = 0; r0 < n_out; r0 += og.rows)
      wide_column(group_out(r0, c), ldo, w + r0 * wr, wr, wm, X + c, ldx, xg, ni, ng, std::min(og.rows, n_out - r0));
}

// out[i * ldo + j] = dot(A row i, B row j) over n for i < RT, j < RS: RT x RS vector accumulators, then each summed
// across its lanes, then the scalar tail.
template <typename T, int RT, int RS>
inline void dots_block(T* out, int64_t ldo, const T* A, int64_t lda, const T* Bm, int64_t ldb, int64_t n) {
  using VT = Vec<T>;
  using V = typename VT::V;
  constexpr int L = VT::L;
  V acc[RT][RS];
#pragma GCC unroll 4
  for (int i = 0; i < RT; ++i)
#pragma GCC unroll 4
    for (int j = 0; j < RS; ++j) acc[i][j] = V{};
  int64_t c = 0;
  for (; c + L <= n; c += L) {
    V a[RT], b[RS];
#pragma GCC unroll 4
    for (int i = 0; i < RT; ++i) a[i] = VT::load(A + i * lda + c);
#pragma GCC unroll 4
    for (int j = 0; j < RS; ++j) b[j] = VT::load(Bm + j * ldb + c);
#pragma GCC unroll 4
    for (int i = 0; i < RT; ++i)
#pragma GCC unroll 4
      for (int j = 0; j < RS; ++j) acc[i][j] += a[i] * b[j];
  }
  for (int i = 0; i < RT; ++i)
    for (int j = 0; j < RS; ++j) {
      T s = 0;
      for (int l = 0; l < L; ++l) s += acc[i][j][l];
      for (int64_t r = c; r < n; ++r) s += A[i * lda + r] * Bm[j * ldb + r];
      out[i * ldo + j] = s;
    }
}

// out (na x nb, row stride ldo) = A (na rows, lda) B^T (nb rows, ldb) over n columns: blocks of 4x4 dot products
// (2x4 in the 16 ymm registers), single rows and columns at the edges.
template <typename T>
void dots_matrix(T* out, int64_t ldo, const T* A, int64_t lda, int64_t na, const T* Bm, int64_t ldb, int64_t nb,
                 int64_t n) {
  constexpr int RT = kVecBytes == 64 ? 4 : 2, RS = 4;
  auto row_block = [&]<int R>(int64_t i) {
    int64_t j = 0;
    for (; j + RS <= nb; j += RS)
      dots_block<T, R, RS>(out + i * ldo + j, ldo, A + i * lda, lda, Bm + j * ldb, ldb, n);
    for (; j < nb; ++j) dots_block<T, R, 1>(out + i * ldo + j, ldo, A + i * lda, lda, Bm + j * ldb, ldb, n);
  };
  int64_t i = 0;
  for (; i + RT <= na; i += RT) row_block.template operator()<RT>(i);
  for (; i < na; ++i) row_block.template operator()<1>(i);
}

// U = P ctx in work items of one batch row b and kValueCols columns (a multiple of every build's two-vector chunk, so
// each column takes the path it takes in one call over all C): U[h, b] (Tq x C) = P[b, h] ctx_b for every head h,
// each chunk of ctx_b staged once for all of them.
constexpr int64_t kValueCols = 256;
inline int64_t value_items(const AttentionShape& s, int64_t C) { return s.B * ((C + kValueCols - 1) / kValueCols); }
template <typename T>
void heads_values(T* u, const T* att, const AttentionShape& s, const T* ctx, int64_t C, int64_t item) {
  const int64_t blocks = (C + kValueCols - 1) / kValueCols, b = item / blocks, c0 = item % blocks * kValueCols;
  const int64_t B = s.B, H = s.H, Tq = s.Tq, Tk = s.Tk;
  wide_row_sums(u + b * Tq * C + c0, C, att + b * H * Tq * Tk, Tk, 1, ctx + b * Tk * C + c0, C, 0, Tk, 1, H * Tq,
                std::min(kValueCols, C - c0), RowGroups{Tq, B * Tq * C});
}

template <typename T>
void ctx_forward_all(T* u, T* att, T* rstd_q, T* rstd_k, const AttentionHeads<T>& a, const T* ctx, int64_t C) {
  const AttentionShape& s = a.s;
  const int64_t H = s.H, BH = s.B * s.H, Tq = s.Tq, Tk = s.Tk, d = s.d;
  const bool through_scratch = a.q_norm || a.cos_tab;
  const T scale = (T)(1.0 / std::sqrt((double)d));
  const int nt = fused_threads(BH * Tq * Tk * (d + C));
  with_head_dim(d, [&]<int D>() {
    const int64_t tkp = padded_keys<T, D>(Tq, Tk);
#pragma omp parallel num_threads(nt) if (nt > 1)
    {
      HeadScratch<T> sc;
      T* qs = through_scratch ? fused_scratch<T>(3, (Tq + Tk) * d) : nullptr;
#pragma omp for schedule(static)
      for (int64_t bh = 0; bh < BH; ++bh) {
        const int64_t b = bh / H, h = bh % H;
        HeadRows<T> x{a.q + b * Tq * a.ldq + h * d, a.k + b * Tk * a.ldk + h * d, nullptr, nullptr, a.ldq, a.ldk, 0,
                      0};
        if (through_scratch) head_qk_to_scratch(x, qs, a, bh, rstd_q, rstd_k);
        head_probs_any<T, D>(x, att + bh * Tq * Tk, a.key_mask ? a.key_mask + b * Tk : nullptr, Tq, Tk, d, tkp,
                             s.causal, scale, sc);
      }
#pragma omp for schedule(static)
      for (int64_t item = 0; item < value_items(s, C); ++item) heads_values(u, att, s, ctx, C, item);
    }
  });
}

template <typename T>
void ctx_values_all(T* u, const T* att, const AttentionShape& s, const T* ctx, int64_t C) {
  const int nt = fused_threads(s.B * s.H * s.Tq * s.Tk * C);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t item = 0; item < value_items(s, C); ++item) heads_values(u, att, s, ctx, C, item);
}

template <typename T>
void ctx_backward_all(T* dq, int64_t lddq, T* dk, int64_t lddk, T* dctx, T* dq_norm, T* dk_norm, const T* du,
                      const T* att, const T* rstd_q, const T* rstd_k, const AttentionHeads<T>& a, const T* ctx,
                      int64_t C) {
  const AttentionShape& s = a.s;
  const int64_t B = s.B, H = s.H, Tq = s.Tq, Tk = s.Tk, d = s.d;
  const bool norm = a.q_norm != nullptr, through_scratch = norm || a.cos_tab;
  const bool need_dq = dq || (norm && dq_norm), need_dk = dk || (norm && dk_norm);
  const T scale = (T)(1.0 / std::sqrt((double)d));
  const int nt = fused_threads(B * H * Tq * Tk * (d + C));
  T* partial = norm && (dq_norm || dk_norm) ? fused_scratch<T>(0, (int64_t)nt * 2 * d) : nullptr;  // [u][q | k]
  if (partial) std::memset(partial, 0, sizeof(T) * nt * 2 * d);
  with_head_dim(d, [&]<int D>() {
    const int64_t tkp = padded_keys<T, D>(Tq, Tk), ldds = ds_stride<T, D>(Tk, tkp);
#pragma omp parallel num_threads(nt) if (nt > 1)
    {
      const int u = omp_get_thread_num();
      const auto [b0, b1] = row_range(B, u, omp_get_num_threads());
      HeadScratch<T> sc;  // scores: dP, then dS, of one head
      T* qs = through_scratch ? fused_scratch<T>(3, (Tq + Tk) * d) : nullptr;      // q, k as the attention saw them
      T* gs = through_scratch ? fused_scratch<T>(4, (Tq + Tk + 1) * d) : nullptr;  // their gradients, a spare row
      T* pq = partial && dq_norm ? partial + (int64_t)u * 2 * d : nullptr;
      T* pk = partial && dk_norm ? partial + (int64_t)u * 2 * d + d : nullptr;
      for (int64_t b = b0; b < b1; ++b) {
        const T* ctx_b = ctx + b * Tk * C;
        for (int64_t h = 0; (need_dq || need_dk) && h < H; ++h) {
          const int64_t bh = b * H + h;
          const T* p = att + bh * Tq * Tk;
          T* ds = sc.scores;
          dots_matrix(ds, ldds, du + (h * B + b) * Tq * C, C, Tq, ctx_b, C, Tk, C);  // dP = dU ctx_b^T
          const T* qx = a.q + b * Tq * a.ldq + h * d;
          const T* kx = a.k + b * Tk * a.ldk + h * d;
          T* dqh = dq ? dq + b * Tq * lddq + h * d : nullptr;
          T* dkh = dk ? dk + b * Tk * lddk + h * d : nullptr;
          HeadRows<T> x{qx, kx, nullptr, nullptr, a.ldq, a.ldk, 0, 0};
          HeadGradRows<T> gr{dqh, dkh, nullptr, lddq, lddk, 0};
          if (through_scratch) {
            head_qk_to_scratch(x, qs, a, bh, (T*)nullptr, (T*)nullptr);
            gr.dq = need_dq ? gs : nullptr, gr.dk = need_dk ? gs + Tq * d : nullptr, gr.ldq = gr.ldk = d;
          }
          head_grads_from_dp_any<T, D>(gr, x, p, ds, Tq, Tk, d, tkp, scale);
          if (through_scratch)
            head_qk_from_scratch(dqh, lddq, dkh, lddk, pq, pk, gr, gs, qx, kx, a, bh, rstd_q, rstd_k);
        }
        // dctx_b (Tk x C) = sum over heads h and queries t of P[b, h, t, :]^T dU[h, b, t]
        if (dctx)
          wide_row_sums(dctx + b * Tk * C, C, att + b * H * Tq * Tk, 1, Tk, du + b * Tq * C, C, B * Tq * C, Tq, H, Tk,
                        C);
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
