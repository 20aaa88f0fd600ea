// gemm_avx512.cpp — AVX-512 micro-kernels (zmm FMAs) and their packing; compiled with AVX-512 flags and only
// called after a run-time check (__builtin_cpu_supports("avx512f")).
//
// float: a 12×32 tile = 12 rows × 2 zmm = 24 accumulators + 2 B vectors (26 of the 32 zmm registers); per k
// it loads 2 vectors of B and broadcasts 12 values of A (embedded {1to16} broadcasts), 24 FMAs.
// double: the same shape in doubles (12×16, 2 zmm of 8 per row).
#include <immintrin.h>

#include "tensor/gemm_kernel.h"
#include "tensor/gemm_simd_kernel.h"

namespace t2m::gemm_detail {
namespace {

constexpr int kMrF = 12, kNvF = 2, kNrF = 16 * kNvF;
constexpr int kMrD = 12, kNvD = 2, kNrD = 8 * kNvD;

// The SIMD traits of gemm_simd_kernel.h for zmm registers (the broadcast compiles to an embedded {1toN} operand).
struct Zmm32 {
  using T = float;
  using Reg = __m512;
  static constexpr int kLanes = 16;
  static Reg zero() { return _mm512_setzero_ps(); }
  static Reg load(const T* p) { return _mm512_load_ps(p); }
  static Reg loadu(const T* p) { return _mm512_loadu_ps(p); }
  static void storeu(T* p, Reg r) { _mm512_storeu_ps(p, r); }
  static void stream(T* p, Reg r) { _mm512_stream_ps(p, r); }
  static Reg bcast(const T* p) { return _mm512_set1_ps(*p); }
  static Reg set1(T x) { return _mm512_set1_ps(x); }
  static Reg fmadd(Reg a, Reg b, Reg c) { return _mm512_fmadd_ps(a, b, c); }
  static Reg mul(Reg a, Reg b) { return _mm512_mul_ps(a, b); }
};
struct Zmm64 {
  using T = double;
  using Reg = __m512d;
  static constexpr int kLanes = 8;
  static Reg zero() { return _mm512_setzero_pd(); }
  static Reg load(const T* p) { return _mm512_load_pd(p); }
  static Reg loadu(const T* p) { return _mm512_loadu_pd(p); }
  static void storeu(T* p, Reg r) { _mm512_storeu_pd(p, r); }
  static Reg bcast(const T* p) { return _mm512_set1_pd(*p); }
  static Reg set1(T x) { return _mm512_set1_pd(x); }
  static Reg fmadd(Reg a, Reg b, Reg c) { return _mm512_fmadd_pd(a, b, c); }
  static Reg mul(Reg a, Reg b) { return _mm512_mul_pd(a, b); }
};

// GCC 12 flags the _mm512_undefined_ps() placeholder inside the unpack/shuffle intrinsics as maybe-uninitialized
// once they are inlined here (a false positive; -Wuninitialized in the -O2 sanitizer build); silence it for the
// transposing packers only.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#endif
// In-register transpose of a 16×16 float block: r[i] holds row i on entry, column i on exit.
inline void transpose16x16(__m512 r[16]) {
  __m512 t[16];
  for (int i = 0; i < 16; i += 2) {  // interleave 32-bit elements of row pairs
    t[i] = _mm512_unpacklo_ps(r[i], r[i + 1]);
    t[i + 1] = _mm512_unpackhi_ps(r[i], r[i + 1]);
  }
  for (int i = 0; i < 16; i += 4) {  // interleave 64-bit pairs
    const __m512d a = _mm512_castps_pd(t[i]), b = _mm512_castps_pd(t[i + 1]);
    const __m512d c = _mm512_castps_pd(t[i + 2]), d = _mm512_castps_pd(t[i + 3]);
    r[i + 0] = _mm512_castpd_ps(_mm512_unpacklo_pd(a, c));
    r[i + 1] = _mm512_castpd_ps(_mm512_unpackhi_pd(a, c));
    r[i + 2] = _mm512_castpd_ps(_mm512_unpacklo_pd(b, d));
    r[i + 3] = _mm512_castpd_ps(_mm512_unpackhi_pd(b, d));
  }
  for (int h = 0; h < 16; h += 8)  // gather 128-bit lanes, 4 rows apart
    for (int i = 0; i < 4; ++i) {
      t[h + i] = _mm512_shuffle_f32x4(r[h + i], r[h + i + 4], 0x88);
      t[h + i + 4] = _mm512_shuffle_f32x4(r[h + i], r[h + i + 4], 0xdd);
    }
  for (int i = 0; i < 8; ++i) {  // and 8 rows apart
    r[i] = _mm512_shuffle_f32x4(t[i], t[i + 8], 0x88);
    r[i + 8] = _mm512_shuffle_f32x4(t[i], t[i + 8], 0xdd);
  }
}

// Plain-copy packing (op(A) = A^T, op(B) = B) in the order of pack_rows_into_panels (gemm_kernel.h): blocks of
// kPackRows source rows, every panel's piece of them, next block prefetched; each packed row of W floats is one or
// two masked zmm moves (the last panel's mask also zero-fills its padding).
template <int W>
void pack_rows_avx512(int64_t kc, int64_t nc, const float* src, int64_t ld, float* out) {
  constexpr int NV = (W + 15) / 16;
  auto lane_mask = [](int64_t n, int v) {  // lanes of vector v holding one of the first n columns
    const int64_t m = n - 16 * v;
    return __mmask16(m >= 16 ? 0xffff : m <= 0 ? 0 : (1u << m) - 1);
  };
  __mmask16 full[NV];
  for (int v = 0; v < NV; ++v) full[v] = lane_mask(W, v);
  for (int64_t k0 = 0; k0 < kc; k0 += kPackRows) {
    const int kb = kc - k0 < kPackRows ? int(kc - k0) : kPackRows;
    for (int u = 0; u < kb; ++u)  // never faults
      _mm_prefetch(reinterpret_cast<const char*>(src + (k0 + kPackRows + u) * ld), _MM_HINT_T0);
    float* dst = out + k0 * W;
    for (int64_t j0 = 0; j0 < nc; j0 += W, dst += kc * W) {
      __mmask16 load[NV];
      for (int v = 0; v < NV; ++v) load[v] = lane_mask(nc - j0, v);
      for (int u = 0; u < kb; ++u) {
        const float* s = src + (k0 + u) * ld + j0;
        for (int v = 0; v < NV; ++v)
          _mm512_mask_storeu_ps(dst + u * W + 16 * v, full[v], _mm512_maskz_loadu_ps(load[v], s + 16 * v));
      }
    }
  }
}

// op(B) = B^T (the forward of a linear layer, x W^T): full 32-row panels go through 16×16 register transposes,
// one group of 16 source rows at a time, each walked to the end of kc with its lines prefetched 4 ahead (the next
// group's first lines once the end is near). Reading all 32 rows of a panel side by side ran at 9-14 GB/s from
// memory on one core of the AMD host; 16 rows with the prefetch run at 19-23 GB/s, the rate of the plain row copy
// (bench/RESULTS.md, session 18). The rest (k tail, partial panel) through the generic packer.
void pack_b_f32(bool trans, int64_t kc, int64_t nc, const float* b, int64_t ldb, float* bp) {
  if (!trans) return pack_rows_avx512<kNrF>(kc, nc, b, ldb, bp);
  constexpr int64_t kAhead = 64;  // floats: 4 cache lines
  const int64_t full = nc / kNrF * kNrF, k16 = kc / 16 * 16;
  for (int64_t j0 = 0; j0 < nc; j0 += kNrF, bp += kc * kNrF) {
    const float* src = b + j0 * ldb;
    if (nc - j0 < kNrF) {
      pack_b_panels<float, kNrF>(true, kc, nc - j0, src, ldb, bp);
      continue;
    }
    for (int h = 0; h < kNrF; h += 16) {
      const float* rows = src + h * ldb;
      const bool next_group = j0 + h + 16 < full;  // the next 16 source rows belong to a full panel too
      for (int64_t k = 0; k < k16; k += 16) {
        const int64_t ahead = k + kAhead;
        if (ahead < kc || next_group) {
          const float* pf = ahead < kc ? rows + ahead : rows + 16 * ldb + (ahead - kc);
          for (int i = 0; i < 16; ++i) _mm_prefetch(reinterpret_cast<const char*>(pf + i * ldb), _MM_HINT_T0);
        }
        __m512 r[16];
        for (int i = 0; i < 16; ++i) r[i] = _mm512_loadu_ps(rows + i * ldb + k);
        transpose16x16(r);
        for (int i = 0; i < 16; ++i) _mm512_store_ps(bp + (k + i) * kNrF + h, r[i]);
      }
    }
    for (int64_t k = k16; k < kc; ++k)
      for (int j = 0; j < kNrF; ++j) bp[k * kNrF + j] = src[j * ldb + k];
  }
}

// op(A) = A (row-major, the usual case): each full 12-row panel goes through 16×16 register transposes (rows 12..15
// zero) and 12-lane masked stores; with N as small as 256 the packing of A is otherwise ~10% of the time.
void pack_a_f32(bool trans, int64_t mc, int64_t kc, const float* a, int64_t lda, float* ap) {
  if (trans) return pack_rows_avx512<kMrF>(kc, mc, a, lda, ap);
  static_assert(kMrF <= 16, "one zmm holds a packed column of A");
  constexpr __mmask16 kRows = __mmask16((1u << kMrF) - 1);
  for (int64_t i0 = 0; i0 < mc; i0 += kMrF, ap += kc * kMrF) {
    const float* src = a + i0 * lda;
    if (mc - i0 < kMrF) {
      pack_a_panels<float, kMrF>(false, mc - i0, kc, src, lda, ap);
      continue;
    }
    int64_t k = 0;
    for (; k + 16 <= kc; k += 16) {
      __m512 r[16];
      for (int i = 0; i < kMrF; ++i) r[i] = _mm512_loadu_ps(src + i * lda + k);
      for (int i = kMrF; i < 16; ++i) r[i] = _mm512_setzero_ps();
      transpose16x16(r);
      for (int i = 0; i < 16; ++i) _mm512_mask_storeu_ps(ap + (k + i) * kMrF, kRows, r[i]);
    }
    for (; k < kc; ++k)
      for (int i = 0; i < kMrF; ++i) ap[k * kMrF + i] = src[i * lda + k];
  }
}

#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

void pack_a_f64(bool trans, int64_t mc, int64_t kc, const double* a, int64_t lda, double* ap) {
  pack_a_panels<double, kMrD>(trans, mc, kc, a, lda, ap);
}
void pack_b_f64(bool trans, int64_t kc, int64_t nc, const double* b, int64_t ldb, double* bp) {
  pack_b_panels<double, kNrD>(trans, kc, nc, b, ldb, bp);
}

}  // namespace

// Blocking for Zen5 (48 KB L1d, 1 MB L2/core): A block mc×kc = 192×512×4 B = 384 KB (L2); B block kc×nc =
// 512×4096×4 B = 8 MB (L3). The B micro-panel (512×32×4 B = 64 KB) streams from L2 (176 B per 12 cycles); a long
// kc halves the passes over C against kc = 256 (measured ~4% faster on 1024³ and 4096×2048×512).
const MicroKernel<float>& avx512_kernel_f32() {
  static const MicroKernel<float> k{"avx512", kMrF, kNrF, 192, 512, 4096, &simd_kernel<Zmm32, kMrF, kNvF, true>,
                                    {4, 8},
                                    {&simd_kernel<Zmm32, 4, kNvF, true, kMrF>,
                                     &simd_kernel<Zmm32, 8, kNvF, true, kMrF>},
                                    &pack_a_f32, &pack_b_f32,
                                    &simd_kernel<Zmm32, kMrF, kNvF, true, kMrF, true>,
                                    &simd_kernel_rows<Zmm32, kMrF, kNvF, true>};
  return k;
}
const MicroKernel<double>& avx512_kernel_f64() {
  static const MicroKernel<double> k{"avx512", kMrD, kNrD, 192, 256, 2048, &simd_kernel<Zmm64, kMrD, kNvD, false>,
                                     {0, 0}, {nullptr, nullptr}, &pack_a_f64, &pack_b_f64};
  return k;
}

}  // namespace t2m::gemm_detail
