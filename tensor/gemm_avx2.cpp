// gemm_avx2.cpp — AVX2+FMA micro-kernels (ymm) and their packing; the baseline every x86-64-v3 CPU runs.
//
// float: a 6×16 tile = 6 rows × 2 ymm = 12 accumulators + 2 B vectors + 1 broadcast (15 of 16 ymm registers).
// double: the same shape in doubles (6×8, 2 ymm of 4 per row).
#include <immintrin.h>

#include "tensor/gemm_kernel.h"
#include "tensor/gemm_simd_kernel.h"

namespace t2m::gemm_detail {
namespace {

constexpr int kMrF = 6, kNvF = 2, kNrF = 8 * kNvF;
constexpr int kMrD = 6, kNvD = 2, kNrD = 4 * kNvD;

// The SIMD traits of gemm_simd_kernel.h for ymm registers.
struct Ymm32 {
  using T = float;
  using Reg = __m256;
  static constexpr int kLanes = 8;
  static Reg zero() { return _mm256_setzero_ps(); }
  static Reg load(const T* p) { return _mm256_load_ps(p); }
  static Reg loadu(const T* p) { return _mm256_loadu_ps(p); }
  static void storeu(T* p, Reg r) { _mm256_storeu_ps(p, r); }
  static void stream(T* p, Reg r) { _mm256_stream_ps(p, r); }
  static Reg bcast(const T* p) { return _mm256_broadcast_ss(p); }
  static Reg set1(T x) { return _mm256_set1_ps(x); }
  static Reg fmadd(Reg a, Reg b, Reg c) { return _mm256_fmadd_ps(a, b, c); }
  static Reg mul(Reg a, Reg b) { return _mm256_mul_ps(a, b); }
};
struct Ymm64 {
  using T = double;
  using Reg = __m256d;
  static constexpr int kLanes = 4;
  static Reg zero() { return _mm256_setzero_pd(); }
  static Reg load(const T* p) { return _mm256_load_pd(p); }
  static Reg loadu(const T* p) { return _mm256_loadu_pd(p); }
  static void storeu(T* p, Reg r) { _mm256_storeu_pd(p, r); }
  static Reg bcast(const T* p) { return _mm256_broadcast_sd(p); }
  static Reg set1(T x) { return _mm256_set1_pd(x); }
  static Reg fmadd(Reg a, Reg b, Reg c) { return _mm256_fmadd_pd(a, b, c); }
  static Reg mul(Reg a, Reg b) { return _mm256_mul_pd(a, b); }
};

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
  static const MicroKernel<float> k{"avx2", kMrF, kNrF, 192, 512, 4096, &simd_kernel<Ymm32, kMrF, kNvF, false>,
                                    {2, 4},
                                    {&simd_kernel<Ymm32, 2, kNvF, false, kMrF>,
                                     &simd_kernel<Ymm32, 4, kNvF, false, kMrF>},
                                    &pack_a_f32, &pack_b_f32,
                                    &simd_kernel<Ymm32, kMrF, kNvF, false, kMrF, true>,
                                    &simd_kernel_rows<Ymm32, kMrF, kNvF, false>};
  return k;
}
const MicroKernel<double>& avx2_kernel_f64() {
  static const MicroKernel<double> k{"avx2", kMrD, kNrD, 192, 256, 2048, &simd_kernel<Ymm64, kMrD, kNvD, false>,
                                     {0, 0}, {nullptr, nullptr}, &pack_a_f64, &pack_b_f64};
  return k;
}

}  // namespace t2m::gemm_detail
