// gemm_avx2.cpp — AVX2+FMA micro-kernels (ymm) and their packing; the baseline every x86-64-v3 CPU runs.
//
// float: a 6×16 tile = 6 rows × 2 ymm = 12 accumulators + 2 B vectors + 1 broadcast (15 of 16 ymm registers).
// double: the same shape in doubles (6×8, 2 ymm of 4 per row).
#include <immintrin.h>

#include "tensor/gemm_kernel.h"

namespace t2m::gemm_detail {
namespace {

constexpr int kMrF = 6, kNvF = 2, kNrF = 8 * kNvF;
constexpr int kMrD = 6, kNvD = 2, kNrD = 4 * kNvD;

// C[0:MR, 0:8*NV] = alpha * ap^T bp + beta * C.
template <int MR, int NV>
void kernel_f32(int64_t kc, const float* ap, const float* bp, float* c, int64_t ldc, float alpha, float beta) {
  __m256 acc[MR][NV];
#pragma GCC unroll 16
  for (int i = 0; i < MR; ++i)
#pragma GCC unroll 4
    for (int v = 0; v < NV; ++v) acc[i][v] = _mm256_setzero_ps();
  for (int64_t k = 0; k < kc; ++k) {
    __m256 b[NV];
#pragma GCC unroll 4
    for (int v = 0; v < NV; ++v) b[v] = _mm256_load_ps(bp + 8 * v);
#pragma GCC unroll 16
    for (int i = 0; i < MR; ++i) {
      const __m256 a = _mm256_broadcast_ss(ap + i);
#pragma GCC unroll 4
      for (int v = 0; v < NV; ++v) acc[i][v] = _mm256_fmadd_ps(a, b[v], acc[i][v]);
    }
    ap += MR;
    bp += 8 * NV;
  }
  const __m256 va = _mm256_set1_ps(alpha);
  if (beta == 0.0f) {
#pragma GCC unroll 16
    for (int i = 0; i < MR; ++i)
#pragma GCC unroll 4
      for (int v = 0; v < NV; ++v) _mm256_storeu_ps(c + i * ldc + 8 * v, _mm256_mul_ps(va, acc[i][v]));
  } else {
    const __m256 vb = _mm256_set1_ps(beta);
#pragma GCC unroll 16
    for (int i = 0; i < MR; ++i)
#pragma GCC unroll 4
      for (int v = 0; v < NV; ++v) {
        float* p = c + i * ldc + 8 * v;
        _mm256_storeu_ps(p, _mm256_fmadd_ps(va, acc[i][v], _mm256_mul_ps(vb, _mm256_loadu_ps(p))));
      }
  }
}

template <int MR, int NV>
void kernel_f64(int64_t kc, const double* ap, const double* bp, double* c, int64_t ldc, double alpha,
                double beta) {
  __m256d acc[MR][NV];
#pragma GCC unroll 16
  for (int i = 0; i < MR; ++i)
#pragma GCC unroll 4
    for (int v = 0; v < NV; ++v) acc[i][v] = _mm256_setzero_pd();
  for (int64_t k = 0; k < kc; ++k) {
    __m256d b[NV];
#pragma GCC unroll 4
    for (int v = 0; v < NV; ++v) b[v] = _mm256_load_pd(bp + 4 * v);
#pragma GCC unroll 16
    for (int i = 0; i < MR; ++i) {
      const __m256d a = _mm256_broadcast_sd(ap + i);
#pragma GCC unroll 4
      for (int v = 0; v < NV; ++v) acc[i][v] = _mm256_fmadd_pd(a, b[v], acc[i][v]);
    }
    ap += MR;
    bp += 4 * NV;
  }
  const __m256d va = _mm256_set1_pd(alpha);
  if (beta == 0.0) {
#pragma GCC unroll 16
    for (int i = 0; i < MR; ++i)
#pragma GCC unroll 4
      for (int v = 0; v < NV; ++v) _mm256_storeu_pd(c + i * ldc + 4 * v, _mm256_mul_pd(va, acc[i][v]));
  } else {
    const __m256d vb = _mm256_set1_pd(beta);
#pragma GCC unroll 16
    for (int i = 0; i < MR; ++i)
#pragma GCC unroll 4
      for (int v = 0; v < NV; ++v) {
        double* p = c + i * ldc + 4 * v;
        _mm256_storeu_pd(p, _mm256_fmadd_pd(va, acc[i][v], _mm256_mul_pd(vb, _mm256_loadu_pd(p))));
      }
  }
}

void pack_a_f32(bool trans, int64_t mc, int64_t kc, const float* a, int64_t lda, float* ap) {
  pack_a_panels<float, kMrF>(trans, mc, kc, a, lda, ap);
}
void pack_b_f32(bool trans, int64_t kc, int64_t nc, const float* b, int64_t ldb, float* bp) {
  pack_b_panels<float, kNrF>(trans, kc, nc, b, ldb, bp);
}
void pack_a_f64(bool trans, int64_t mc, int64_t kc, const double* a, int64_t lda, double* ap) {
  pack_a_panels<double, kMrD>(trans, mc, kc, a, lda, ap);
}
void pack_b_f64(bool trans, int64_t kc, int64_t nc, const double* b, int64_t ldb, double* bp) {
  pack_b_panels<double, kNrD>(trans, kc, nc, b, ldb, bp);
}

}  // namespace

// B micro-panel kc×nr = 512×16×4 B = 32 KB (L1); A block 192×512×4 B = 384 KB (L2); B block 8 MB (L3).
const MicroKernel<float>& avx2_kernel_f32() {
  static const MicroKernel<float> k{"avx2", kMrF, kNrF, 192, 512, 4096, &kernel_f32<kMrF, kNvF>, &pack_a_f32,
                                    &pack_b_f32};
  return k;
}
const MicroKernel<double>& avx2_kernel_f64() {
  static const MicroKernel<double> k{"avx2", kMrD, kNrD, 192, 256, 2048, &kernel_f64<kMrD, kNvD>, &pack_a_f64,
                                     &pack_b_f64};
  return k;
}

}  // namespace t2m::gemm_detail
