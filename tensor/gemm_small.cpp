// gemm_small.cpp — the unpacked GEMM path for matrix-vector-like and tiny products (gemm_small.h): row by row,
// either accumulating rows of B (op(B) = B) or dot products with 8 partial sums (op(B) = B^T, or a K x 1 column).
#include "tensor/gemm_small.h"

#include <omp.h>

#include <algorithm>
#include <cmath>

#include "tensor/gemm_buffer.h"

namespace t2m::gemm_detail {
namespace {

thread_local PackBuffer tls_small;  // a row of N + K elements

// Rows [i0, i1) of C. op(B) row-major (no trans): C[i,:] accumulates a[i,k] * B[k,:] (vectorised along N).
// op(B) = B^T, or a contiguous K×1 column: C[i,j] = dot(op(A)[i,:], column j of op(B)) with 8 partial sums
// (vectorised along K).
template <typename T>
void gemm_small_rows(const GemmArgs<T>& g, int64_t i0, int64_t i1) {
  T* tmp = tls_small.get<T>(g.N + g.K);
  const bool dot_form = g.tb || (g.N == 1 && g.ldb == 1);
  for (int64_t i = i0; i < i1; ++i) {
    T* c = g.C + i * g.ldc;
    if (!dot_form) {
      std::fill(tmp, tmp + g.N, T(0));
      for (int64_t k = 0; k < g.K; ++k) {
        const T a = *g.a_at(i, k);
        const T* b = g.B + k * g.ldb;
        for (int64_t j = 0; j < g.N; ++j) tmp[j] = std::fma(a, b[j], tmp[j]);
      }
    } else {
      const T* a = g.a_at(i, 0);
      if (g.ta) {  // gather the strided row of op(A) once
        T* arow = tmp + g.N;
        for (int64_t k = 0; k < g.K; ++k) arow[k] = g.A[k * g.lda + i];
        a = arow;
      }
      int64_t j = 0;
      if (g.tb) {  // four columns at once: four independent accumulator chains, each summed as in the loop below
        for (; j + 4 <= g.N; j += 4) {
          const T* b = g.B + j * g.ldb;
          T s[4][8] = {};
          int64_t k = 0;
          for (; k + 8 <= g.K; k += 8)
            for (int q = 0; q < 4; ++q)
              for (int u = 0; u < 8; ++u) s[q][u] = std::fma(a[k + u], b[q * g.ldb + k + u], s[q][u]);
          for (; k < g.K; ++k)
            for (int q = 0; q < 4; ++q) s[q][0] = std::fma(a[k], b[q * g.ldb + k], s[q][0]);
          for (int q = 0; q < 4; ++q)
            tmp[j + q] = ((s[q][0] + s[q][4]) + (s[q][1] + s[q][5])) + ((s[q][2] + s[q][6]) + (s[q][3] + s[q][7]));
        }
      }
      for (; j < g.N; ++j) {
        const T* b = g.tb ? g.B + j * g.ldb : g.B;
        T s[8] = {};
        int64_t k = 0;
        for (; k + 8 <= g.K; k += 8)
          for (int u = 0; u < 8; ++u) s[u] = std::fma(a[k + u], b[k + u], s[u]);
        for (; k < g.K; ++k) s[0] = std::fma(a[k], b[k], s[0]);
        tmp[j] = ((s[0] + s[4]) + (s[1] + s[5])) + ((s[2] + s[6]) + (s[3] + s[7]));
      }
    }
    if (g.beta == T(0)) {
      if (g.bias) {
        for (int64_t j = 0; j < g.N; ++j) c[j] = std::fma(g.alpha, tmp[j], g.bias[j]);
      } else {
        for (int64_t j = 0; j < g.N; ++j) c[j] = g.alpha * tmp[j];
      }
    } else {
      for (int64_t j = 0; j < g.N; ++j) c[j] = std::fma(g.alpha, tmp[j], g.beta * c[j]);
    }
  }
}

}  // namespace

template <typename T>
void gemm_small(const GemmArgs<T>& g, int nt) {
  if (nt <= 1 || g.M < 2 * nt) {
    gemm_small_rows(g, 0, g.M);
    return;
  }
#pragma omp parallel num_threads(nt)
  {
    const int t = omp_get_thread_num(), team = omp_get_num_threads();
    gemm_small_rows(g, g.M * t / team, g.M * (t + 1) / team);
  }
}

template void gemm_small<float>(const GemmArgs<float>&, int);
template void gemm_small<double>(const GemmArgs<double>&, int);

}  // namespace t2m::gemm_detail
