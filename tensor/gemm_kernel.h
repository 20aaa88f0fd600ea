// gemm_kernel.h — internal to tensor/gemm*.cpp: the micro-kernel table and the panel-packing routines.
//
// The blocked GEMM (gemm.cpp) follows the GotoBLAS/BLIS loop nest. Row-major C is vectorised along N:
//   jc over N step nc: pc over K step kc: pack op(B)[pc:+kc, jc:+nc] into nr-wide panels (kc×nr each)
//     ic over M step mc: pack op(A)[ic:+mc, pc:+kc] into mr-tall panels (kc×mr each)
//       jr over the B panels: ir over the A panels: micro-kernel updates the mr×nr tile of C.
// (gemm.cpp may pack several K blocks at once, `pack depth`; each K block of kc is still one kernel call.)
// Packed layouts (both k-major, zero padded to a full panel):
//   A panel p: ap[p*kc*mr + k*mr + i] = op(A)[p*mr + i, k]      (i < mr)
//   B panel q: bp[q*kc*nr + k*nr + j] = op(B)[k, q*nr + j]      (j < nr)
// A micro-kernel computes C[0:mr, 0:nr] = alpha * sum_k ap[k,:]^T bp[k,:] + beta * C (beta == 0: C never read)
// with the final update done as fma(alpha, acc, beta*c) (beta == 0 with a bias row: fma(alpha, acc, bias[j])), in
// k order, so every element's arithmetic depends only on its own row/column data (results do not depend on the
// thread split).
#pragma once
#include <cmath>
#include <cstdint>

namespace t2m::gemm_detail {

template <typename T>
struct MicroKernel {
  const char* name;
  int mr, nr;          // register tile
  int64_t mc, kc, nc;  // cache blocking: A block mc×kc (L2), B micro-panel kc×nr (L1), B block kc×nc (L3)
  void (*kernel)(int64_t kc, const T* ap, const T* bp, T* c, int64_t ldc, T alpha, T beta, const T* bias);
  // Kernels for the short last panel of C (m < mr rows, full nr columns), reading the first rows of an mr-wide A
  // panel and writing only those rows: short_kernel[i] serves m == short_m[i] exactly (null: none).
  // Without them a short panel costs a full mr-row kernel into a scratch tile plus a copy (for M = 256 and mr = 12
  // that is 3% more kernel work).
  int short_m[2];
  void (*short_kernel[2])(int64_t kc, const T* ap, const T* bp, T* c, int64_t ldc, T alpha, T beta, const T* bias);
  void (*pack_a)(bool trans, int64_t mc, int64_t kc, const T* a, int64_t lda, T* ap);
  void (*pack_b)(bool trans, int64_t kc, int64_t nc, const T* b, int64_t ldb, T* bp);
  // The full tile's kernel with non-temporal stores (beta == 0, no bias, C rows aligned to kStreamAlign bytes): for
  // a C written once and not read again soon (gemm_stream). Null: none, the plain kernel serves.
  void (*kernel_stream)(int64_t kc, const T* ap, const T* bp, T* c, int64_t ldc, T alpha, T beta,
                        const T* bias) = nullptr;
  // The full tile's kernel reading op(A) = A where it is stored (row i at a + i * lda, k contiguous) instead of a
  // packed panel; the same bits as kernel. Null: none, A is packed.
  void (*kernel_rows)(int64_t kc, const T* a, int64_t lda, const T* bp, T* c, int64_t ldc, T alpha, T beta,
                      const T* bias) = nullptr;
};
constexpr int kStreamAlign = 64;

// Defined in gemm_avx512.cpp (requires avx512f at run time) and gemm_avx2.cpp (AVX2+FMA baseline).
const MicroKernel<float>& avx512_kernel_f32();
const MicroKernel<float>& avx2_kernel_f32();
const MicroKernel<double>& avx512_kernel_f64();
const MicroKernel<double>& avx2_kernel_f64();

// Packing, shared by every ISA file (plain C++; each file compiles it with its own vector flags).
// Plain-copy packing (op(A) = A^T stored kc×mc, op(B) = B stored kc×nc): each packed row is a contiguous run of
// the source row. The source is walked in blocks of kPackRows rows: every panel takes its piece of those rows
// before the next block starts, and the next block's rows are prefetched. Walking one panel down all kc rows
// instead reads 48-128 bytes per row and jumps a row stride (often a whole page) each time: 2-4x slower from
// memory for row strides of 1024-3072 floats.
constexpr int kPackRows = 8;

// dst[u * W + j] = src[u * ld + j] for u < rows, j < n, zero for n <= j < W.
template <typename T, int W>
inline void copy_rows_padded(T* dst, const T* src, int64_t ld, int rows, int64_t n) {
  for (int u = 0; u < rows; ++u) {
    const T* s = src + u * ld;
    T* d = dst + u * W;
    if (n == W) {
      for (int j = 0; j < W; ++j) d[j] = s[j];
    } else {
      for (int j = 0; j < W; ++j) d[j] = j < n ? s[j] : T(0);
    }
  }
}

// Panels of width W from a row-major kc×nc source (row stride ld): panel p gets columns [p W, p W + W), rows in
// order, zero padded; the layout of both pack_a (trans) and pack_b (no trans).
template <typename T, int W>
void pack_rows_into_panels(int64_t kc, int64_t nc, const T* src, int64_t ld, T* out) {
  for (int64_t k0 = 0; k0 < kc; k0 += kPackRows) {
    const int kb = kc - k0 < kPackRows ? int(kc - k0) : kPackRows;
    for (int u = 0; u < kb; ++u) __builtin_prefetch(src + (k0 + kPackRows + u) * ld);  // never faults
    T* dst = out + k0 * W;
    for (int64_t j0 = 0; j0 < nc; j0 += W, dst += kc * W)
      copy_rows_padded<T, W>(dst, src + k0 * ld + j0, ld, kb, nc - j0 < W ? nc - j0 : W);
  }
}

// Panels of width W from a column-major source: panel p gets source rows [p W, p W + W) (row stride ld), as
// columns: out[k * W + i] = src[(p W + i) * ld + k] for k < kc, zero padded past nc rows. The layout of both
// pack_a (no trans) and pack_b (trans).
template <typename T, int W>
void pack_transposed_into_panels(int64_t kc, int64_t nc, const T* src, int64_t ld, T* out) {
  for (int64_t i0 = 0; i0 < nc; i0 += W, out += kc * W) {
    const int64_t n = nc - i0 < W ? nc - i0 : W;
    const T* s0 = src + i0 * ld;
    if (n == W) {
      // Four k at a time keeps the strided writes of one source row in few cache lines.
      int64_t k = 0;
      for (; k + 4 <= kc; k += 4)
        for (int i = 0; i < W; ++i) {
          const T* s = s0 + i * ld + k;
          out[(k + 0) * W + i] = s[0];
          out[(k + 1) * W + i] = s[1];
          out[(k + 2) * W + i] = s[2];
          out[(k + 3) * W + i] = s[3];
        }
      for (; k < kc; ++k)
        for (int i = 0; i < W; ++i) out[k * W + i] = s0[i * ld + k];
    } else {
      for (int64_t k = 0; k < kc; ++k)
        for (int i = 0; i < W; ++i) out[k * W + i] = i < n ? s0[i * ld + k] : T(0);
    }
  }
}

// pack_a_panels: op(A) is mc×kc; trans means A is stored kc×mc (A[k*lda + i]).
template <typename T, int MR>
void pack_a_panels(bool trans, int64_t mc, int64_t kc, const T* a, int64_t lda, T* ap) {
  if (trans) return pack_rows_into_panels<T, MR>(kc, mc, a, lda, ap);
  pack_transposed_into_panels<T, MR>(kc, mc, a, lda, ap);
}

// pack_b_panels: op(B) is kc×nc; trans means B is stored nc×kc (B[j*ldb + k]).
template <typename T, int NR>
void pack_b_panels(bool trans, int64_t kc, int64_t nc, const T* b, int64_t ldb, T* bp) {
  if (!trans) return pack_rows_into_panels<T, NR>(kc, nc, b, ldb, bp);
  pack_transposed_into_panels<T, NR>(kc, nc, b, ldb, bp);
}

}  // namespace t2m::gemm_detail
