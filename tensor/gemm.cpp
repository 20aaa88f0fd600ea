// gemm.cpp — the GEMM driver: run-time kernel choice, the GotoBLAS/BLIS loop nest over packed panels (see
// gemm_kernel.h for the layouts), the thread split, the choice of the unpacked path for small shapes (gemm_small.cpp),
// the ReLU epilogue, non-temporal C stores (gemm_stream), and the entry points (argument checks in gemm_args.h).
#include "tensor/gemm.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <tuple>

#include <unistd.h>
#include <xmmintrin.h>

#include "tensor/cpu_features.h"
#include "tensor/gemm_args.h"
#include "tensor/gemm_buffer.h"
#include "tensor/gemm_columns.h"
#include "tensor/gemm_kernel.h"
#include "tensor/gemm_small.h"
#include "tensor/gemm_steal.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"

namespace t2m {
namespace {

using gemm_detail::check_args;
using gemm_detail::PackBuffer;
using gemm_detail::gemm_small;
using gemm_detail::GemmArgs;
using gemm_detail::is_small;
using gemm_detail::MicroKernel;
using gemm_detail::segment_col;
using gemm_detail::segment_left;
using gemm_detail::StealRange;

int64_t ceil_div(int64_t a, int64_t b) { return (a + b - 1) / b; }
int64_t round_up(int64_t a, int64_t b) { return ceil_div(a, b) * b; }

thread_local PackBuffer tls_pack_a, tls_pack_b;

// ---- kernel choice -------------------------------------------------------------------------------------------

enum KernelId : int { kAuto = 0, kAvx512 = 1, kAvx2 = 2 };
std::atomic<int> g_forced_kernel{kAuto};

KernelId chosen_kernel() {
  const int f = g_forced_kernel.load(std::memory_order_relaxed);
  if (f != kAuto) return KernelId(f);
  return cpu_has_avx512() ? kAvx512 : kAvx2;
}
template <typename T>
const MicroKernel<T>& select_kernel();
template <>
const MicroKernel<float>& select_kernel<float>() {
  return chosen_kernel() == kAvx512 ? gemm_detail::avx512_kernel_f32() : gemm_detail::avx2_kernel_f32();
}
template <>
const MicroKernel<double>& select_kernel<double>() {
  return chosen_kernel() == kAvx512 ? gemm_detail::avx512_kernel_f64() : gemm_detail::avx2_kernel_f64();
}

// ---- packed depth ---------------------------------------------------------------------------------------------

// Float products of more than one row block (M > MC) pack two K blocks at once where L2 holds such an A block next
// to the B micro-panels (2 MB and more: 192 x 1024 floats = 768 KB): half the packing rounds, and half the barriers
// of the threaded splits. On the Intel host (2 MB L2) `t2m bench --threads 2` read 1024^3 and the fb shapes
// 1.5-4 % faster (1024x1024x614:nt 299 -> 310 GFLOP/s) and fm-paper B32 Tm8 612-624 -> 602-605 ms, but 32-row
// products 5-15 % slower (32x256x1536 199-209 -> 172-174); with 1 MB of L2 (the AMD host) it stays at one block.
std::atomic<int> g_forced_depth{0};
int auto_pack_depth() {
  static const int d = gemm_l2_bytes() >= (2l << 20) ? 2 : 1;
  return d;
}
template <typename T>
int64_t pack_depth(int64_t M, int64_t MC) {
  if (sizeof(T) != sizeof(float)) return 1;
  const int f = g_forced_depth.load(std::memory_order_relaxed);
  return f ? f : M > MC ? auto_pack_depth() : 1;
}

// ---- non-temporal C stores (gemm_stream) ----------------------------------------------------------------------

// Whether the packed path writes C's full tiles with non-temporal stores: asked for (gemm_stream), the kernel has
// them, each tile is one kernel call (beta == 0, no epilogue, K within one arithmetic block), C is at least as large
// as the L2 (it would not stay there anyway) and its rows are aligned for the stores. Edge tiles stay plain.
template <typename T>
bool streams_c(const MicroKernel<T>& uk, const GemmArgs<T>& g) {
  return g.stream && uk.kernel_stream && g.beta == T(0) && !g.bias && !g.relu && g.K <= uk.kc && !g.segmented() &&
         g.M * g.N * int64_t(sizeof(T)) >= gemm_l2_bytes() &&
         reinterpret_cast<uintptr_t>(g.C) % gemm_detail::kStreamAlign == 0 &&
         g.ldc * int64_t(sizeof(T)) % gemm_detail::kStreamAlign == 0;
}

// ---- op(A) read in place --------------------------------------------------------------------------------------

// Whether the packed path reads op(A) = A where it is stored (MicroKernel::kernel_rows) instead of packing it: the
// same FMAs in the same order, so the same bits; only the short last row panel of a block is packed. Packing A
// costs one pass over A per product (per thread without a shared A), and pays off when each A panel meets many B
// panels: with at most 512 columns per thread reading in place was 1-5 % faster (fm-paper's 512- and 768-row
// products, 1024^3), with 768-2048 columns 1-2 % slower, at M = 32 (one row block) ~1 % slower (bench/RESULTS.md,
// session 41). Not when A's rows lie a multiple of 4 KB apart (K = 1024, 2048, 3072 floats): the kernel's mr rows
// then fall in one L1 set (4 KB per way on every host so far), more lines than its ways, and the product ran ~10 %
// slower in place than packed (768x1024x1024:nt 98 against 108 GFLOP/s on 1 thread, 200 against 216 on 2, AMD Zen 4
// host; with lda 1040 in place read 107 / 221), session 44. Forced (gemm_force_read_a) for tests and benchmarks.
std::atomic<int> g_read_a{0};  // 0 automatic, 1 packed, 2 in place where possible
std::atomic<int64_t> g_in_place_products{0};
constexpr int64_t kL1WayBytes = 4096;
template <typename T>
bool reads_a_in_place(const MicroKernel<T>& uk, const GemmArgs<T>& g, int64_t cols_per_thread, bool stream) {
  if (!uk.kernel_rows || g.ta || g.ac.len || stream) return false;
  const int f = g_read_a.load(std::memory_order_relaxed);
  const bool rows_alias = g.lda * int64_t(sizeof(T)) % kL1WayBytes == 0;
  return f == 2 || (f == 0 && g.M > uk.mc && cols_per_thread <= 512 && !rows_alias);
}

// ---- C = beta C (K == 0 or alpha == 0) -----------------------------------------------------------------------

// f(c, j0, n) over every row of C by runs of contiguous columns (the whole row when C is plain): c points at
// column j0 of the row, n columns long.
template <typename T, typename F>
void for_each_c_run(const GemmArgs<T>& g, F f) {
  for (int64_t i = 0; i < g.M; ++i)
    for (int64_t j0 = 0; j0 < g.N;) {
      const int64_t n = std::min(g.N - j0, segment_left(g.cc, j0));
      f(g.c_at(i, j0), j0, n);
      j0 += n;
    }
}

template <typename T>
void scale_c(const GemmArgs<T>& g) {
  for_each_c_run(g, [&](T* c, int64_t j0, int64_t n) {
    if (g.bias) {
      std::copy(g.bias + j0, g.bias + j0 + n, c);
    } else if (g.beta == T(0)) {
      std::fill(c, c + n, T(0));
    } else if (g.beta != T(1)) {
      for (int64_t j = 0; j < n; ++j) c[j] *= g.beta;
    }
  });
}

// ---- the ReLU epilogue ----------------------------------------------------------------------------------------

// c[j] = max(c[j], 0) over one run of n elements, with relu's NaN and -0 behaviour (x < 0 ? 0 : x).
template <typename T>
void relu_run(T* c, int64_t n) {
  for (int64_t j = 0; j < n; ++j) c[j] = c[j] < T(0) ? T(0) : c[j];
}

// The ReLU over all of C, for the paths without a tile epilogue (small shapes, K == 0).
template <typename T>
void relu_c(const GemmArgs<T>& g) {
  for_each_c_run(g, [](T* c, int64_t, int64_t n) { relu_run(c, n); });
}

// ---- the packed path ------------------------------------------------------------------------------------------

// The C block at rows from `c` (row stride ldc), columns [j0, j0 + nc) (stored in segments cs), from packed A
// (mc×kc; or, when ar is not null, A's full row panels read in place, row i at ar + i * lda, and ap holding only
// the short last panel) and packed B (kc×nc). The packed depth kc may span several arithmetic K blocks of uk.kc:
// each tile runs one kernel call per K block, back to back (the tile stays in L1 between them), with beta and the
// bias on the first and the ReLU after the last: every C element gets the same operations, in the same order, as
// with one packing round per K block. A short last row panel whose height has a kernel of its own
// (MicroKernel::short_m) runs it on C directly; other edge tiles, and tiles whose columns straddle a segment
// boundary, go through a local tile so that the micro-kernel always runs full-size.
template <typename T>
void macro_kernel(const MicroKernel<T>& uk, int64_t mc, int64_t nc, int64_t kc, const T* ap, const T* ar,
                  int64_t lda, const T* bp, T* c, int64_t ldc, const GemmColumns& cs, int64_t j0, T alpha, T beta,
                  const T* bias, bool relu, bool stream) {
  const int mr = uk.mr, nr = uk.nr;
  const int64_t ks = uk.kc;  // the arithmetic K block
  alignas(64) T tile[32 * 64];
  auto relu_rows = [&](T* cc, int64_t m) {  // the ReLU epilogue on m rows of a tile stored straight into C
    if (relu)
      for (int64_t i = 0; i < m; ++i) relu_run(cc + i * ldc, nr);
  };
  // One row of an edge tile from the local tile t: n columns at row, with beta b and bias bias_j.
  auto store_row = [&](T* row, const T* t, T b, const T* bias_j, int64_t n) {
    if (b == T(0) && bias_j) {
      for (int64_t j = 0; j < n; ++j) row[j] = std::fma(alpha, t[j], bias_j[j]);
    } else if (b == T(0)) {
      for (int64_t j = 0; j < n; ++j) row[j] = alpha * t[j];
    } else {
      for (int64_t j = 0; j < n; ++j) row[j] = std::fma(alpha, t[j], b * row[j]);
    }
  };
  for (int64_t jr = 0; jr < nc; jr += nr) {
    const int64_t n = std::min<int64_t>(nr, nc - jr);
    const T* b = bp + (jr / nr) * kc * nr;
    const T* bias_j = bias ? bias + jr : nullptr;
    const bool one_run = segment_left(cs, j0 + jr) >= n;  // the tile's columns are contiguous in C
    for (int64_t ir = 0; ir < mc; ir += mr) {
      const int64_t m = std::min<int64_t>(mr, mc - ir);
      const bool rows = ar && m == mr;  // A read in place (uk.kernel_rows); ap then holds only the short panel
      const T* a = rows ? ar + ir * lda : ar ? ap : ap + (ir / mr) * kc * mr;
      // The tile's K block at k0 into d (row stride ld): from A in place, or from the packed panel by `packed`.
      auto block = [&](auto packed, int64_t k0, T* d, int64_t ld, T al, T be, const T* bi) {
        if (rows)
          uk.kernel_rows(std::min(ks, kc - k0), a + k0, lda, b + k0 * nr, d, ld, al, be, bi);
        else
          packed(std::min(ks, kc - k0), a + k0 * mr, b + k0 * nr, d, ld, al, be, bi);
      };
      T* cc = c + ir * ldc + segment_col(cs, j0 + jr);
      const int s = !one_run || n < nr ? -1 : m == uk.short_m[0] ? 0 : m == uk.short_m[1] ? 1 : -1;
      if (one_run && n == nr && (m == mr || (s >= 0 && uk.short_kernel[s]))) {  // straight into C
        const auto kernel = m < mr ? uk.short_kernel[s] : stream ? uk.kernel_stream : uk.kernel;
        if (beta != T(0))  // the kernel reads C only at its end: start pulling the tile in (beta == 0 only writes)
          for (int64_t i = 0; i < m; ++i) {
            __builtin_prefetch(cc + i * ldc, 1);
            __builtin_prefetch(cc + i * ldc + nr - 1, 1);
          }
        for (int64_t k0 = 0; k0 < kc; k0 += ks)
          block(kernel, k0, cc, ldc, alpha, k0 == 0 ? beta : T(1), k0 == 0 ? bias_j : nullptr);
        relu_rows(cc, m);
        continue;
      }
      for (int64_t k0 = 0; k0 < kc; k0 += ks) {
        block(uk.kernel, k0, tile, nr, T(1), T(0), nullptr);
        const bool last = k0 + ks >= kc;
        for (int64_t i = 0; i < m; ++i)
          for (int64_t j = 0; j < n;) {  // by runs of contiguous columns: one, unless the tile straddles a segment
            const int64_t run = std::min(n - j, segment_left(cs, j0 + jr + j));
            T* row = c + (ir + i) * ldc + segment_col(cs, j0 + jr + j);
            store_row(row, tile + i * nr + j, k0 == 0 ? beta : T(1), k0 == 0 && bias_j ? bias_j + j : nullptr, run);
            if (relu && last) relu_run(row, run);
            j += run;
          }
      }
    }
  }
}

// op(A)[ic : ic + mc, pc : pc + kc] and op(B)[pc : pc + kc, jc : jc + nc] into the panel layouts of gemm_kernel.h
// (the plain packers, or gemm_columns.h's segment walk around them).
template <typename T>
void pack_a_block(const MicroKernel<T>& uk, const GemmArgs<T>& g, int64_t ic, int64_t mc, int64_t pc, int64_t kc,
                  T* ap) {
  if (!g.ac.len) return uk.pack_a(g.ta, mc, kc, g.a_at(ic, pc), g.lda, ap);
  gemm_detail::pack_segmented(g.ta, uk.mr, g.A, g.lda, g.ac, ic, mc, pc, kc, ap,
                              [&](const T* src, int64_t np, int64_t nd, T* out) {
                                uk.pack_a(g.ta, np, nd, src, g.lda, out);
                              });
}
template <typename T>
void pack_b_block(const MicroKernel<T>& uk, const GemmArgs<T>& g, int64_t pc, int64_t kc, int64_t jc, int64_t nc,
                  T* bp) {
  if (!g.bc.len) return uk.pack_b(g.tb, kc, nc, g.b_at(pc, jc), g.ldb, bp);
  gemm_detail::pack_segmented(!g.tb, uk.nr, g.B, g.ldb, g.bc, jc, nc, pc, kc, bp,
                              [&](const T* src, int64_t np, int64_t nd, T* out) {
                                uk.pack_b(g.tb, nd, np, src, g.ldb, out);
                              });
}

// Threads split C by rows (each packs its own A blocks; the B block is packed once, cooperatively, and shared;
// once a thread's rows are done it steals B panels of the others' rows, packing their A block itself) or, when M
// is at most 1024 rows or too short for a row split, by columns (each packs its own B panels and the whole A
// block, or from 512 rows its share of a shared A block; once its columns are done it steals (row block, B panel)
// items of the others' columns, reading their packed B and packing the A block itself unless it is shared).
// Every C tile is computed by one kernel call per K block from the same packed data whichever thread takes it, so
// stealing (or sharing) does not change a bit of the result. Returns whether C was streamed (streams_c).
template <typename T>
bool gemm_packed(const MicroKernel<T>& uk, const GemmArgs<T>& g, int nt) {
  // KC: the packed depth, one or more arithmetic K blocks of uk.kc (macro_kernel runs them one by one).
  const int64_t mr = uk.mr, nr = uk.nr, MC = uk.mc, KC = uk.kc * pack_depth<T>(g.M, uk.mc), NC = uk.nc;
  const int64_t m_tiles = ceil_div(g.M, mr), n_tiles = ceil_div(g.N, nr);
  nt = int(std::max<int64_t>(1, std::min<int64_t>(nt, std::max(m_tiles, n_tiles))));
  // Up to 1024 rows, with enough B panels for every thread, split by columns: each thread packs its own B panels
  // and the whole A block. On the AMD host this ran the fm-paper shapes (512-768 rows) 6-12 % faster on 2 threads
  // than the shared-B row split (`t2m bench --threads 2 --shapes 512x2048x512,...`), and 4096x512x512 5 % slower,
  // hence the row limit. Past 512 rows, a product with N <= M / 2 still splits by rows: its B block is small to
  // share, while every thread reading and packing all of A cost 2-7 % on the Intel host (`t2m bench --threads 2
  // --shapes 1024x256x1024:nt,1024x512x1024:nt,768x256x1024:nt,1024x256x512,...`, both splits forced in turn).
  const bool split_n = nt > 1 && g.M <= 1024 && n_tiles >= 4 * nt && (g.M <= 512 || 2 * g.N > g.M);
  const bool split_m = !split_n && (nt == 1 || m_tiles >= 4 * nt || m_tiles >= n_tiles);
  // Stealing between column shares needs the same rounds (K blocks) in every thread: each share in one NC block.
  const bool steal_n = split_n && ceil_div(n_tiles, nt) * nr <= NC;
  // With stealing and at least 512 rows, the column shares also share packed A: each K block of op(A) (all rows)
  // is packed once, cooperatively, instead of once per thread, at the cost of a second barrier per K block (which
  // made 256-row products 2-4 % slower, e.g. 256x256x4096:nt).
  const bool stream = streams_c(uk, g);  // each thread fences its streamed stores before the region ends
  // op(A) = A, plain: the kernel reads A's rows where they are stored; only a short last panel is packed.
  const bool ua = reads_a_in_place(uk, g, split_n ? ceil_div(n_tiles, nt) * nr : g.N, stream);
  if (ua) g_in_place_products.fetch_add(1, std::memory_order_relaxed);
  const bool share_a = steal_n && nt > 1 && g.M >= 512 && !ua;
  // With one row block (M <= MC: the adaLN products, M = 32) every B panel is used once: when op(B) = B^T (its
  // panels are runs of whole source rows), each is packed right before its use into an L2-resident buffer, instead
  // of a whole B block (1.5-3 MB per thread) written out to L3 and read back.
  const bool lazy_b = steal_n && nt > 1 && g.M <= MC && g.tb;
  T* shared_bp = split_m ? tls_pack_b.get<T>(KC * round_up(std::min(NC, g.N), nr)) : nullptr;
  T* shared_ap = share_a ? tls_pack_a.get<T>(round_up(g.M, mr) * KC) : nullptr;
  std::unique_ptr<StealRange[]> ranges((split_m || steal_n) && nt > 1 ? new StealRange[nt] : nullptr);
  std::unique_ptr<T*[]> own_bp(steal_n ? new T*[nt] : nullptr);  // each thread's packed B (split by columns)
  // op(A)'s block [ic, ic + mc) x [pc, pc + kc) for macro_kernel: packed into ap, or (ua) only its short last
  // panel packed, the full ones read in place.
  auto prepare_a = [&](int64_t ic, int64_t mc, int64_t pc, int64_t kc, T* ap) {
    if (!ua) return pack_a_block(uk, g, ic, mc, pc, kc, ap);
    const int64_t full = mc / mr * mr;
    if (full < mc) pack_a_block(uk, g, ic + full, mc - full, pc, kc, ap);
  };
  auto a_rows = [&](int64_t ic, int64_t pc) { return ua ? g.A + ic * g.lda + pc : nullptr; };
  auto cols_of = [&](int u, int team) {  // thread u's share of the columns (split by columns)
    return std::make_pair(std::min(g.N, n_tiles * u / team * nr), std::min(g.N, n_tiles * (u + 1) / team * nr));
  };
#pragma omp parallel num_threads(nt) if (nt > 1)
  {
    const int t = omp_get_thread_num(), team = omp_get_num_threads();
    auto rows_of = [&](int u) {  // thread u's share of the rows (split_m)
      return std::make_pair(std::min(g.M, m_tiles * u / team * mr), std::min(g.M, m_tiles * (u + 1) / team * mr));
    };
    int64_t m0 = 0, m1 = g.M, n0 = 0, n1 = g.N;
    if (split_m)
      std::tie(m0, m1) = rows_of(t);
    else
      std::tie(n0, n1) = cols_of(t, team);
    T* ap = share_a ? shared_ap
                    : tls_pack_a.get<T>(round_up(std::min(MC, std::max<int64_t>(split_m ? g.M : m1 - m0, 1)), mr) * KC);
    T* bp = split_m  ? shared_bp
            : lazy_b ? tls_pack_b.get<T>(KC * nr)
                     : tls_pack_b.get<T>(KC * round_up(std::min(NC, std::max<int64_t>(n1 - n0, 1)), nr));
    if (own_bp) own_bp[t] = bp;  // published with the first round's items
    int64_t round = 0;
    for (int64_t jc = n0; jc < n1; jc += NC) {
      const int64_t nc = std::min(NC, n1 - jc);
      for (int64_t pc = 0; pc < g.K; pc += KC, ++round) {
        const int64_t kc = std::min(KC, g.K - pc);
        const T beta = pc == 0 ? g.beta : T(1);
        const T* bias = pc == 0 && g.bias ? g.bias + jc : nullptr;  // the bias joins in the first K block
        const bool relu = g.relu && pc + kc >= g.K;                    // the ReLU follows the last one
        const int64_t panels = ceil_div(nc, nr);
        if (split_m) {
          if (ranges) ranges[t].reset(ceil_div(m1 - m0, MC) * panels);  // published by the barrier below
          const int64_t p0 = panels * t / team, p1 = panels * (t + 1) / team;  // this thread's B panels
          if (p1 > p0) pack_b_block(uk, g, pc, kc, jc + p0 * nr, std::min(p1 * nr, nc) - p0 * nr, bp + p0 * kc * nr);
#pragma omp barrier
        } else {
          // Shared A: this thread's micro-panels of the strip (every ic is a multiple of mr: the layout of packing
          // block by block), published with the rest by the barrier below.
          if (share_a) {
            const int64_t q0 = m_tiles * t / team * mr, q1 = std::min(g.M, m_tiles * (t + 1) / team * mr);
            if (q1 > q0) pack_a_block(uk, g, q0, q1 - q0, pc, kc, ap + q0 * kc);
          }
          if (!lazy_b) pack_b_block(uk, g, pc, kc, jc, nc, bp);
          if (ranges) {
            ranges[t].reset(ceil_div(m1 - m0, MC) * panels);
            ranges[t].publish(round);
          }
          if (share_a) {
#pragma omp barrier
          }
        }
        if (!ranges) {  // one thread, or split by columns without stealing: this thread's rows in order
          for (int64_t ic = m0; ic < m1; ic += MC) {
            const int64_t mc = std::min(MC, m1 - ic);
            prepare_a(ic, mc, pc, kc, ap);
            macro_kernel(uk, mc, nc, kc, ap, a_rows(ic, pc), g.lda, bp, g.C + ic * g.ldc, g.ldc, g.cc, jc, g.alpha,
                         beta, bias, relu, stream);
          }
        } else {
          // Thread u's share: rows [r0, r1) against the columns [c, c + n) whose B panels are packed at b (split by
          // rows: u's rows, this round's shared B block; by columns: all rows, u's columns and u's packed B).
          // Item i of a share: row block i / panels, B panel i % panels. Own items first, then steal from the back
          // (by columns the last row block, whose A is usually the one this thread packed last).
          struct Share {
            int64_t r0, r1, c, n;
            const T* b;
          };
          auto share_of = [&](int u) {
            if (split_m) return Share{rows_of(u).first, rows_of(u).second, jc, nc, bp};
            const auto [c0, c1] = cols_of(u, team);
            return Share{0, g.M, c0, c1 - c0, u == t ? bp : own_bp[u]};
          };
          int64_t packed_ic = -1;  // first row of the block whose A is in ap
          for (int k = 0; k < team; ++k) {
            const int u = (t + k) % team;
            if (!split_m && k != 0) ranges[u].wait_for(round);  // by rows the barrier above published it
            const Share sh = share_of(u);
            const int64_t pu = ceil_div(sh.n, nr);
            const T* bias_u = pc == 0 && g.bias ? g.bias + sh.c : nullptr;
            for (int64_t item; (item = ranges[u].take(k != 0)) >= 0;) {
              const int64_t ic = sh.r0 + item / pu * MC, mc = std::min(MC, sh.r1 - ic), p = item % pu;
              if (!share_a && ic != packed_ic) {
                prepare_a(ic, mc, pc, kc, ap);
                packed_ic = ic;
              }
              const T* a = share_a ? ap + ic * kc : ap;
              const int64_t n = std::min(nr, sh.n - p * nr);
              if (lazy_b) pack_b_block(uk, g, pc, kc, sh.c + p * nr, n, bp);
              macro_kernel(uk, mc, n, kc, a, a_rows(ic, pc), g.lda, lazy_b ? bp : sh.b + p * kc * nr,
                           g.C + ic * g.ldc, g.ldc, g.cc, sh.c + p * nr, g.alpha, beta,
                           bias_u ? bias_u + p * nr : nullptr, relu, stream);
            }
          }
        }
        // The shared B block (split_m), or the B blocks others may still read (stealing), are re-packed next
        // round: wait until everyone is done with them (the region's closing barrier covers the last round).
        if (ranges && (jc + nc < n1 || pc + kc < g.K)) {
#pragma omp barrier
        }
      }
    }
    if (stream) _mm_sfence();  // the non-temporal stores are visible before anyone reads C
  }
  return stream;
}

// Threads worth using for a problem of M·N·K multiply-adds (a fork/join costs a few microseconds).
int threads_for(int64_t work) {
  if (omp_in_parallel()) return 1;
  if (work < (int64_t(1) << 18)) return 1;
  return std::max(1, get_num_threads());
}

// Returns whether C was streamed (streams_c).
template <typename T>
bool gemm_run(const GemmArgs<T>& g, int nt) {
  if (g.M == 0 || g.N == 0) return false;
  if (g.K == 0 || g.alpha == T(0)) {
    scale_c(g);
  } else if (is_small(g) && !g.segmented()) {
    gemm_small(g, nt);
  } else {
    return gemm_packed(select_kernel<T>(), g, nt);  // the ReLU, if any, ran on each tile
  }
  if (g.relu) relu_c(g);
  return false;
}

// One product through the public entry points; `op` names the entry point in errors. Returns whether C was
// streamed (gemm_stream).
template <typename T>
bool gemm_one(bool ta, bool tb, int64_t M, int64_t N, int64_t K, T alpha, const T* A, int64_t lda, const T* B,
              int64_t ldb, T beta, T* C, int64_t ldc, const T* bias = nullptr, GemmColumns ac = {},
              GemmColumns bc = {}, GemmColumns cc = {}, const char* op = "gemm", bool relu = false,
              bool stream = false) {
  const GemmArgs<T> g{ta, tb, M, N, K, alpha, A, lda, B, ldb, bias ? T(0) : beta, C, ldc, bias, relu, ac, bc, cc,
                      stream};
  check_args(op, g);
  return gemm_run(g, threads_for(M * N * K));
}

template <typename T>
void gemm_batch(bool ta, bool tb, int64_t batch, int64_t M, int64_t N, int64_t K, T alpha, const T* A,
                int64_t lda, int64_t sa, const T* B, int64_t ldb, int64_t sb, T beta, T* C, int64_t ldc,
                int64_t sc) {
  const GemmArgs<T> g0{ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, C, ldc};
  check_args("gemm_batched", g0);
  if (batch < 0 || sa < 0 || sb < 0 || sc < 0)
    throw Error("gemm_batched: negative batch or stride (batch=" + std::to_string(batch) + " stride_a=" +
                std::to_string(sa) + " stride_b=" + std::to_string(sb) + " stride_c=" + std::to_string(sc) + ")");
  if (batch == 0 || M == 0 || N == 0) return;
  const int64_t per = M * N * K;
  const int nt = threads_for(per * batch);
  auto at = [&](int64_t b) {
    return GemmArgs<T>{ta, tb, M, N, K, alpha, A + b * sa, lda, B + b * sb, ldb, beta, C + b * sc, ldc};
  };
  // One whole GEMM per thread when the matrices are small and there are enough of them, or when the batch splits
  // evenly over the threads (the Winograd convolutions' 4 or 6 tap products: no barrier inside the products and
  // no shared packing; on the AMD host this took 5-10 % off a vae B256 T64 step). stride_c == 0 (every product
  // accumulates into the same C) stays sequential.
  if (nt > 1 && batch >= nt && (per < (int64_t(1) << 21) || batch % nt == 0) && sc != 0) {
    select_kernel<T>();  // initialise the CPU-feature statics before the threads start
#pragma omp parallel for schedule(dynamic, 1) num_threads(nt)  // whole products: any order gives the same bits
    for (int64_t b = 0; b < batch; ++b) gemm_run(at(b), 1);
    return;
  }
  for (int64_t b = 0; b < batch; ++b) gemm_run(at(b), threads_for(per));
}

}  // namespace

void gemm(bool ta, bool tb, int64_t M, int64_t N, int64_t K, float alpha, const float* A, int64_t lda,
          const float* B, int64_t ldb, float beta, float* C, int64_t ldc) {
  gemm_one(ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, C, ldc);
}
void gemm(bool ta, bool tb, int64_t M, int64_t N, int64_t K, double alpha, const double* A, int64_t lda,
          const double* B, int64_t ldb, double beta, double* C, int64_t ldc) {
  gemm_one(ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, C, ldc);
}
void gemm_bias(bool ta, bool tb, int64_t M, int64_t N, int64_t K, float alpha, const float* A, int64_t lda,
               const float* B, int64_t ldb, const float* bias, float* C, int64_t ldc) {
  gemm_one(ta, tb, M, N, K, alpha, A, lda, B, ldb, 0.0f, C, ldc, bias);
}
void gemm_bias(bool ta, bool tb, int64_t M, int64_t N, int64_t K, double alpha, const double* A, int64_t lda,
               const double* B, int64_t ldb, const double* bias, double* C, int64_t ldc) {
  gemm_one(ta, tb, M, N, K, alpha, A, lda, B, ldb, 0.0, C, ldc, bias);
}
bool gemm_stream(bool ta, bool tb, int64_t M, int64_t N, int64_t K, float alpha, const float* A, int64_t lda,
                 const float* B, int64_t ldb, float* C, int64_t ldc) {
  return gemm_one(ta, tb, M, N, K, alpha, A, lda, B, ldb, 0.0f, C, ldc, static_cast<const float*>(nullptr), {}, {},
                  {}, "gemm_stream", false, true);
}
bool gemm_stream(bool ta, bool tb, int64_t M, int64_t N, int64_t K, double alpha, const double* A, int64_t lda,
                 const double* B, int64_t ldb, double* C, int64_t ldc) {
  return gemm_one(ta, tb, M, N, K, alpha, A, lda, B, ldb, 0.0, C, ldc, static_cast<const double*>(nullptr), {}, {},
                  {}, "gemm_stream", false, true);
}
void gemm_bias_relu(bool ta, bool tb, int64_t M, int64_t N, int64_t K, float alpha, const float* A, int64_t lda,
                    const float* B, int64_t ldb, const float* bias, float* C, int64_t ldc) {
  gemm_one(ta, tb, M, N, K, alpha, A, lda, B, ldb, 0.0f, C, ldc, bias, {}, {}, {}, "gemm_bias_relu", true);
}
void gemm_bias_relu(bool ta, bool tb, int64_t M, int64_t N, int64_t K, double alpha, const double* A,
                    int64_t lda, const double* B, int64_t ldb, const double* bias, double* C, int64_t ldc) {
  gemm_one(ta, tb, M, N, K, alpha, A, lda, B, ldb, 0.0, C, ldc, bias, {}, {}, {}, "gemm_bias_relu", true);
}
void gemm_batched(bool ta, bool tb, int64_t batch, int64_t M, int64_t N, int64_t K, float alpha, const float* A,
                  int64_t lda, int64_t sa, const float* B, int64_t ldb, int64_t sb, float beta, float* C,
                  int64_t ldc, int64_t sc) {
  gemm_batch(ta, tb, batch, M, N, K, alpha, A, lda, sa, B, ldb, sb, beta, C, ldc, sc);
}
void gemm_batched(bool ta, bool tb, int64_t batch, int64_t M, int64_t N, int64_t K, double alpha, const double* A,
                  int64_t lda, int64_t sa, const double* B, int64_t ldb, int64_t sb, double beta, double* C,
                  int64_t ldc, int64_t sc) {
  gemm_batch(ta, tb, batch, M, N, K, alpha, A, lda, sa, B, ldb, sb, beta, C, ldc, sc);
}

void gemm_segmented(bool ta, bool tb, int64_t M, int64_t N, int64_t K, float alpha, const float* A, int64_t lda,
                    GemmColumns ac, const float* B, int64_t ldb, GemmColumns bc, float beta, float* C, int64_t ldc,
                    GemmColumns cc) {
  gemm_one(ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, C, ldc, static_cast<const float*>(nullptr), ac, bc, cc,
           "gemm_segmented");
}
void gemm_segmented(bool ta, bool tb, int64_t M, int64_t N, int64_t K, double alpha, const double* A, int64_t lda,
                    GemmColumns ac, const double* B, int64_t ldb, GemmColumns bc, double beta, double* C,
                    int64_t ldc, GemmColumns cc) {
  gemm_one(ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, C, ldc, static_cast<const double*>(nullptr), ac, bc, cc,
           "gemm_segmented");
}

int64_t gemm_l2_bytes() {
  static const int64_t b = std::max<int64_t>(sysconf(_SC_LEVEL2_CACHE_SIZE), 256 << 10);
  return b;
}

int gemm_force_pack_depth(int blocks) {
  if (blocks < 0 || blocks > 8)
    throw Error("gemm_force_pack_depth: blocks must be 0 (automatic) to 8, got " + std::to_string(blocks));
  g_forced_depth.store(blocks);
  return auto_pack_depth();
}

int64_t gemm_force_read_a(const char* mode) {
  const std::string m = mode ? mode : "";
  if (m == "auto") {
    g_read_a.store(0);
  } else if (m == "packed") {
    g_read_a.store(1);
  } else if (m == "in_place") {
    g_read_a.store(2);
  } else {
    throw Error("gemm_force_read_a: unknown mode '" + m + "' (expected auto, packed or in_place)");
  }
  return g_in_place_products.load();
}

const char* gemm_kernel_name() { return chosen_kernel() == kAvx512 ? "avx512" : "avx2"; }

void gemm_force_kernel(const char* name) {
  const std::string n = name ? name : "";
  if (n == "auto") {
    g_forced_kernel.store(kAuto);
  } else if (n == "avx512") {
    if (!cpu_has_avx512()) throw Error("gemm_force_kernel: this CPU lacks AVX-512 (avx512f/bw/dq/vl)");
    g_forced_kernel.store(kAvx512);
  } else if (n == "avx2") {
    if (!cpu_has_avx2()) throw Error("gemm_force_kernel: this CPU lacks AVX2+FMA");
    g_forced_kernel.store(kAvx2);
  } else {
    throw Error("gemm_force_kernel: unknown kernel '" + n + "' (expected avx512, avx2 or auto)");
  }
}

}  // namespace t2m
