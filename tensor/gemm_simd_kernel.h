// gemm_simd_kernel.h — internal to tensor/gemm_*.cpp: the register-blocked micro-kernel written once over a SIMD
// traits type, instantiated by each ISA file (compiled with its own vector flags) for float and double.
//
// V provides: T (element), Reg (vector register), kLanes, zero(), load(p) (aligned), loadu(p), storeu(p, r),
// bcast(p) (broadcast *p), set1(x), fmadd(a, b, c) = a*b + c, mul(a, b); for the Stream variant also stream(p, r)
// (a non-temporal store to an aligned p).
#pragma once
#include <cstdint>

namespace t2m::gemm_detail {

// The tile's end: C[0:MR, 0:kLanes*NV] = alpha * acc + beta * C (beta == 0: C never read; with a bias row
// fma(alpha, acc, bias[j]); Stream: non-temporal stores, see simd_kernel).
template <typename V, int MR, int NV, bool Stream>
inline void store_tile(const typename V::Reg (&acc)[MR][NV], typename V::T* c, int64_t ldc, typename V::T alpha,
                       typename V::T beta, const typename V::T* bias) {
  using R = typename V::Reg;
  constexpr int L = V::kLanes;
  const R va = V::set1(alpha);
  if (beta == typename V::T(0) && bias) {
    R bv[NV];
#pragma GCC unroll 4
    for (int v = 0; v < NV; ++v) bv[v] = V::loadu(bias + L * v);
#pragma GCC unroll 32
    for (int i = 0; i < MR; ++i)
#pragma GCC unroll 4
      for (int v = 0; v < NV; ++v) V::storeu(c + i * ldc + L * v, V::fmadd(va, acc[i][v], bv[v]));
  } else if (beta == typename V::T(0)) {
#pragma GCC unroll 32
    for (int i = 0; i < MR; ++i)
#pragma GCC unroll 4
      for (int v = 0; v < NV; ++v) {
        if constexpr (Stream)
          V::stream(c + i * ldc + L * v, V::mul(va, acc[i][v]));
        else
          V::storeu(c + i * ldc + L * v, V::mul(va, acc[i][v]));
      }
  } else {
    const R vb = V::set1(beta);
#pragma GCC unroll 32
    for (int i = 0; i < MR; ++i)
#pragma GCC unroll 4
      for (int v = 0; v < NV; ++v) {
        typename V::T* p = c + i * ldc + L * v;
        V::storeu(p, V::fmadd(va, acc[i][v], V::mul(vb, V::loadu(p))));
      }
  }
}

// B's NV vectors at step k and, with Prefetch, its row 16 steps on (each of its cache lines).
template <typename V, int NV, bool Prefetch>
inline void load_b_row(typename V::Reg (&b)[NV], const typename V::T* bp) {
  constexpr int L = V::kLanes;
#pragma GCC unroll 4
  for (int v = 0; v < NV; ++v) b[v] = V::load(bp + L * v);
  if (Prefetch)
    for (int l = 0; l < L * NV * int(sizeof(*bp)); l += 64)
      __builtin_prefetch(reinterpret_cast<const char*>(bp + 16 * L * NV) + l);
}

// C[0:MR, 0:kLanes*NV] = alpha * ap^T bp + beta * C (beta == 0: C never read; then bias, when not null, is added to
// every row as fma(alpha, acc, bias[j]): the bias epilogue of a linear layer); packed layouts as in gemm_kernel.h,
// the A panel AS rows wide (AS > MR: the first MR rows of a wider panel, for the short last panel of C). Per k: NV
// vectors of B, MR broadcasts of A, MR*NV FMAs into the accumulators; Prefetch pulls the A panel 8 and the B panel
// 16 k steps ahead into L1 (a B micro-panel of kc = 512 is larger than L1, and the hardware prefetcher alone left
// the fm/fb training steps ~1 % slower on the Intel host). Each C element gets the same FMA chain whatever MR and
// AS, so a short kernel gives the full one's bits. Stream: with beta == 0 and no bias, the tile goes to memory with
// non-temporal stores (V::stream; C's rows must be aligned to the vector width; the caller fences).
template <typename V, int MR, int NV, bool Prefetch, int AS = MR, bool Stream = false>
void simd_kernel(int64_t kc, const typename V::T* ap, const typename V::T* bp, typename V::T* c, int64_t ldc,
                 typename V::T alpha, typename V::T beta, const typename V::T* bias) {
  using R = typename V::Reg;
  constexpr int L = V::kLanes;
  R acc[MR][NV];
#pragma GCC unroll 32
  for (int i = 0; i < MR; ++i)
#pragma GCC unroll 4
    for (int v = 0; v < NV; ++v) acc[i][v] = V::zero();
  for (int64_t k = 0; k < kc; ++k) {
    R b[NV];
    load_b_row<V, NV, Prefetch>(b, bp);
    if (Prefetch) __builtin_prefetch(ap + 8 * AS);
#pragma GCC unroll 32
    for (int i = 0; i < MR; ++i) {
      const R a = V::bcast(ap + i);
#pragma GCC unroll 4
      for (int v = 0; v < NV; ++v) acc[i][v] = V::fmadd(a, b[v], acc[i][v]);
    }
    ap += AS;
    bp += L * NV;
  }
  store_tile<V, MR, NV, Stream>(acc, c, ldc, alpha, beta, bias);
}

// simd_kernel with A read where it is stored, row-major (A[i * lda + k], no packing): the same FMAs in the same
// order, so the same bits as packing A first. For op(A) = A, whose packing interleaves MR rows. No software
// prefetch of A (one line of each row every 16 steps, or of all rows at once, measured slower than the hardware's).
template <typename V, int MR, int NV, bool Prefetch>
void simd_kernel_rows(int64_t kc, const typename V::T* a, int64_t lda, const typename V::T* bp, typename V::T* c,
                      int64_t ldc, typename V::T alpha, typename V::T beta, const typename V::T* bias) {
  using R = typename V::Reg;
  constexpr int L = V::kLanes;
  R acc[MR][NV];
#pragma GCC unroll 32
  for (int i = 0; i < MR; ++i)
#pragma GCC unroll 4
    for (int v = 0; v < NV; ++v) acc[i][v] = V::zero();
  for (int64_t k = 0; k < kc; ++k) {
    R b[NV];
    load_b_row<V, NV, Prefetch>(b, bp);
#pragma GCC unroll 32
    for (int i = 0; i < MR; ++i) {
      const R av = V::bcast(a + i * lda + k);
#pragma GCC unroll 4
      for (int v = 0; v < NV; ++v) acc[i][v] = V::fmadd(av, b[v], acc[i][v]);
    }
    bp += L * NV;
  }
  store_tile<V, MR, NV, false>(acc, c, ldc, alpha, beta, bias);
}

}  // namespace t2m::gemm_detail
