// row_stats.h — internal to tensor/fused/: the mean and 1/sqrt(var + eps) of contiguous rows, four at a time (the
// statistics of LayerNorm rows and GroupNorm (sample, group) blocks).
#pragma once
#include <cmath>
#include <cstdint>

namespace t2m::fused {

// Mean and 1/sqrt(var + eps) of four rows side by side (one row's dependent adds took ~1,300 cycles at C = 1024).
// Each row has its own reduction variable, and GCC vectorises the four exactly as it did the one-row loop this
// replaced (same lanes, same tail, same final order: checked bit for bit against it for C from 1 to 3072, tails
// included); a one-row instance of this function compiled to another order, so a short remainder repeats its
// last row instead.
template <typename T>
inline void row_stats4(const T* x0, const T* x1, const T* x2, const T* x3, int64_t C, T eps, T* m, T* r) {
  T s0 = 0, s1 = 0, s2 = 0, s3 = 0;
#pragma omp simd reduction(+ : s0, s1, s2, s3)
  for (int64_t c = 0; c < C; ++c) {
    s0 += x0[c];
    s1 += x1[c];
    s2 += x2[c];
    s3 += x3[c];
  }
  const T m0 = s0 / (T)C, m1 = s1 / (T)C, m2 = s2 / (T)C, m3 = s3 / (T)C;
  T v0 = 0, v1 = 0, v2 = 0, v3 = 0;
#pragma omp simd reduction(+ : v0, v1, v2, v3)
  for (int64_t c = 0; c < C; ++c) {
    const T d0 = x0[c] - m0, d1 = x1[c] - m1, d2 = x2[c] - m2, d3 = x3[c] - m3;
    v0 += d0 * d0;
    v1 += d1 * d1;
    v2 += d2 * d2;
    v3 += d3 * d3;
  }
  const T ms[4] = {m0, m1, m2, m3}, vs[4] = {v0, v1, v2, v3};
  for (int j = 0; j < 4; ++j) {
    m[j] = ms[j];
    r[j] = (T)1 / std::sqrt(vs[j] / (T)C + eps);
  }
}

// The next group of rows [i, i + rows) of the rows [i, end) of a matrix (row stride ld), rows = min(4, end - i):
// their pointers in x (the last repeated when fewer than four) and their statistics in m and r. Returns rows.
template <typename T>
inline int row_group_stats(const T* first, int64_t ld, int64_t i, int64_t end, int64_t C, T eps, const T* x[4],
                           T m[4], T r[4]) {
  const int rows = int(end - i < 4 ? end - i : 4);
  for (int j = 0; j < 4; ++j) x[j] = first + (i + (j < rows ? j : rows - 1)) * ld;
  row_stats4(x[0], x[1], x[2], x[3], C, eps, m, r);
  return rows;
}

}  // namespace t2m::fused
