// conv1d_winograd.cpp — F(m, 3) in three steps per chunk of samples (the transformed matrices stay in cache):
//   forward:  V[i] (Cin, N) = BT x_tile (input transform);  M[i] (Cout, N) = U[i] (Cout, Cin) @ V[i] for the
//             m + 2 points i (one gemm_batched);  y_tile = AT M + bias (output transform);  U[i] = G w (per call)
//   backward: dM[i] = AT^T dy_tile;  dU[i] += dM[i] @ V[i]^T, dw += G^T dU;  dV[i] = U[i]^T @ dM[i];
//             dx_tile += BT^T dV (tiles overlap: accumulated in a padded row, then folded into x: the causal
//             left pad adds into frame 0, zero padding drops)
// N = tiles of the chunk, column b * nT + j; tiles are enumerated as in the header.
#include "tensor/fused/conv1d_winograd.h"

#include <cstdint>
#include <string>

#include "tensor/fused/kernel_util.h"
#include "tensor/fused/scratch.h"
#include "tensor/gemm.h"

namespace t2m::fused {

namespace {

// Lavin & Gray's matrices. F(2, 3): points 0, 1, -1 (and infinity).
template <int M>
struct Wino;
template <>
struct Wino<2> {
  static constexpr int A = 4;
  static constexpr double BT[4][4] = {{1, 0, -1, 0}, {0, 1, 1, 0}, {0, -1, 1, 0}, {0, 1, 0, -1}};
  static constexpr double G[4][3] = {{1, 0, 0}, {0.5, 0.5, 0.5}, {0.5, -0.5, 0.5}, {0, 0, 1}};
  static constexpr double AT[2][4] = {{1, 1, 1, 0}, {0, 1, -1, -1}};
};
// F(4, 3): points 0, 1, -1, 2, -2 (and infinity).
template <>
struct Wino<4> {
  static constexpr int A = 6;
  static constexpr double BT[6][6] = {{4, 0, -5, 0, 1, 0},  {0, -4, -4, 1, 1, 0}, {0, 4, -4, -1, 1, 0},
                                      {0, -2, -1, 2, 1, 0}, {0, 2, -1, -2, 1, 0}, {0, 4, 0, -5, 0, 1}};
  static constexpr double G[6][3] = {{1.0 / 4, 0, 0},
                                     {-1.0 / 6, -1.0 / 6, -1.0 / 6},
                                     {-1.0 / 6, 1.0 / 6, -1.0 / 6},
                                     {1.0 / 24, 1.0 / 12, 1.0 / 6},
                                     {1.0 / 24, -1.0 / 12, 1.0 / 6},
                                     {0, 0, 1}};
  static constexpr double AT[4][6] = {
      {1, 1, 1, 1, 1, 0}, {0, 1, -1, 2, -2, 0}, {0, 1, 1, 4, 4, 0}, {0, 1, -1, 8, -8, 1}};
};

constexpr int64_t kPairBlock = 256;  // (co, ci) pairs per block of the weight transforms

int64_t tiles_per_sample(int64_t To, int64_t d, int m) {
  const int64_t span = m * d, rem = To % span;
  return d * (To / span) + (rem < d ? rem : d);
}

// Samples per chunk: the larger of V and M (A x max(Cin, Cout) x nb * nT elements) within 4 MB of float.
constexpr int64_t kChunkElems = int64_t{1} << 20;
int64_t chunk_samples(const Conv1dShape& s, int A, int64_t nT) {
  const int64_t c = s.Cin > s.Cout ? s.Cin : s.Cout, per = A * c * nT;
  const int64_t nb = kChunkElems / (per > 0 ? per : 1);
  return nb < 1 ? 1 : (nb > s.B ? s.B : nb);
}

void check_shape(const char* op, const Conv1dShape& s) {
  if (s.K != 3 || s.stride != 1)
    throw Error(std::string(op) + ": Winograd F(m, 3) needs K == 3 and stride == 1, got K=" + std::to_string(s.K) +
                " stride=" + std::to_string(s.stride));
}

int pick_tile(const Conv1dShape& s, int m) {
  if (m == 0) {
    m = conv1d_winograd_tile(s);
    return m ? m : 4;
  }
  if (m != 2 && m != 4) throw Error("conv1d_winograd: tile m must be 2 or 4, got " + std::to_string(m));
  return m;
}

// Per-call shape data shared by the steps.
struct Geo {
  int64_t To, nT, d, padL, N;  // N: tiles in the current chunk
};

// U[i] (Cout, Cin) = sum_k G[i][k] w[co, ci, k].
template <typename T, int M>
void weight_transform(T* U, const T* w, const Conv1dShape& s) {
  using W = Wino<M>;
  const int64_t CC = s.Cout * s.Cin, nblk = (CC + kPairBlock - 1) / kPairBlock;
  const int nt = fused_threads(W::A * CC);
  // Blocks of kPairBlock (co, ci) pairs: the three taps are split out of w's stride-3 rows first, so that the
  // products below run as contiguous vector loops (the same expression per element as one pair at a time).
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t q = 0; q < nblk; ++q) {
    const int64_t c0 = q * kPairBlock, n = CC - c0 < kPairBlock ? CC - c0 : kPairBlock;
    T g0[kPairBlock], g1[kPairBlock], g2[kPairBlock];
    for (int64_t j = 0; j < n; ++j) {
      g0[j] = w[3 * (c0 + j)];
      g1[j] = w[3 * (c0 + j) + 1];
      g2[j] = w[3 * (c0 + j) + 2];
    }
    for (int i = 0; i < W::A; ++i) {
      T* u = U + i * CC + c0;
      const T a = (T)W::G[i][0], b = (T)W::G[i][1], c = (T)W::G[i][2];
      for (int64_t j = 0; j < n; ++j) u[j] = a * g0[j] + b * g1[j] + c * g2[j];
    }
  }
}

// dw[co, ci, k] += sum_i G[i][k] dU[i][co, ci].
template <typename T, int M>
void weight_transform_backward(T* dw, const T* dU, const Conv1dShape& s) {
  using W = Wino<M>;
  const int64_t CC = s.Cout * s.Cin, nblk = (CC + kPairBlock - 1) / kPairBlock;
  const int nt = fused_threads(W::A * CC);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t q = 0; q < nblk; ++q) {
    const int64_t c0 = q * kPairBlock, n = CC - c0 < kPairBlock ? CC - c0 : kPairBlock;
    T acc[3][kPairBlock];
    for (int k = 0; k < 3; ++k) {  // acc over i in order, as one pair at a time would sum it
      for (int64_t j = 0; j < n; ++j) acc[k][j] = 0;
      for (int i = 0; i < W::A; ++i) {
        const T gk = (T)W::G[i][k];
        const T* du = dU + i * CC + c0;
        for (int64_t j = 0; j < n; ++j) acc[k][j] += gk * du[j];
      }
    }
    for (int64_t j = 0; j < n; ++j)
      for (int k = 0; k < 3; ++k) dw[3 * (c0 + j) + k] += acc[k][j];
  }
}

// The tile transforms work on blocks of kChanBlock channels, in two steps each: a copy of the block's frame rows
// of all nb samples of the chunk into a staging buffer (padded as the convolution pads), then per channel one long
// gather (or scatter) between the staged rows and "tap rows" P[k][b * nT + j] = rows_b[base_j + k d] through an
// offset table computed once per chunk, and the small coefficient matrix applied across the N columns of the
// contiguous tap rows (vectorised). Every loop runs over a whole chunk (N columns) rather than one sample's nT
// tiles, and no loop depends on the dilation.

// First (padded) frame of tile j: tiles are walked as (block q, residue r) = (j / d, j % d).
int64_t tile_base(int64_t j, int m, int64_t d) { return m * d * (j / d) + j % d; }

// tap[k * ldt + b * nT + j] = b * ld + tile_base(j) + k d for k < ntap, b < nb, j < nT: where tap k of tile j of
// sample b sits in nb stacked rows of ld frames.
void tap_offsets(int32_t* tap, int ntap, int m, const Geo& g, int64_t nb, int64_t ld, int64_t ldt) {
  if (nb * ld > INT32_MAX)
    throw Error("conv1d_winograd: a chunk of " + std::to_string(nb) + " samples x " + std::to_string(ld) +
                " padded frames overflows the int32 offset table");
  for (int64_t j = 0; j < g.nT; ++j) {
    const int64_t base = tile_base(j, m, g.d);
    for (int k = 0; k < ntap; ++k)
      for (int64_t b = 0; b < nb; ++b) tap[k * ldt + b * g.nT + j] = (int32_t)(b * ld + base + k * g.d);
  }
}

// P[k][n] = rows[tap[k][n]] for k < NTAP, n < N. Not inlined: inside the transforms' lambdas the loop counters
// were kept on the stack (a store-to-load chain per element, 3x slower).
template <typename T, int NTAP>
[[gnu::noinline]] void gather_taps(T* __restrict P, const T* __restrict rows, const int32_t* __restrict tap,
                                   int64_t N) {
  for (int k = 0; k < NTAP; ++k) {
    const int32_t* t = tap + k * N;
    T* p = P + k * N;
    for (int64_t n = 0; n < N; ++n) p[n] = rows[t[n]];
  }
}

// rows[tap[k][n]] += P[k][n], k outer (every frame sums its terms in the order of k).
template <typename T, int NTAP>
[[gnu::noinline]] void scatter_add_taps(T* __restrict rows, const T* __restrict P, const int32_t* __restrict tap,
                                        int64_t N) {
  for (int k = 0; k < NTAP; ++k) {
    const int32_t* t = tap + k * N;
    const T* p = P + k * N;
    for (int64_t n = 0; n < N; ++n) rows[t[n]] += p[n];
  }
}

// xs[(cl * nb + b) * L + p] = the padded frame p of channel c0 + cl of sample b0 + b: nl copies of the left pad
// value (frame 0 when causal, else 0), the nx frames of x, zeros up to L.
template <typename T>
[[gnu::noinline]] void stage_input_rows(T* __restrict xs, const T* __restrict inp, const Conv1dShape& s,
                                        int64_t b0, int64_t nb, int64_t c0, int64_t cn, int64_t L, int64_t nl,
                                        int64_t nx) {
  for (int64_t b = 0; b < nb; ++b)
    for (int64_t cl = 0; cl < cn; ++cl) {
      const T* x = inp + ((b0 + b) * s.Cin + c0 + cl) * s.T;
      T* xp = xs + (cl * nb + b) * L;
      const T left = s.causal ? x[0] : (T)0;
      for (int64_t p = 0; p < nl; ++p) xp[p] = left;
      for (int64_t p = 0; p < nx; ++p) xp[nl + p] = x[p];
      for (int64_t p = nl + nx; p < L; ++p) xp[p] = 0;
    }
}

// out[i][n] = sum_k C[i][k] in[k][n] for n < N (Transposed: C[k][i]); the coefficients are compile-time constants.
template <typename T, int R, int K, bool Transposed, typename Mat>
void combine_rows(T* out, int64_t ldo, const T* in, int64_t ldi, int64_t N, const Mat& C) {
#pragma GCC unroll 6
  for (int i = 0; i < R; ++i) {
    T* o = out + i * ldo;
    for (int64_t n = 0; n < N; ++n) {
      T acc = 0;
#pragma GCC unroll 6
      for (int k = 0; k < K; ++k) acc += (T)(Transposed ? C[k][i] : C[i][k]) * in[k * ldi + n];
      o[n] = acc;
    }
  }
}

// The blocks keep the reads and writes of the staging copies in order: for one sample the frame rows of a block
// are adjacent in memory (kChanBlock * T floats), where one channel at a time would touch a new page per sample.
constexpr int64_t kChanBlock = 8;

// f(c0, cn, blk, rows) for the channel blocks [c0, c0 + cn) of C channels, split statically over the threads; blk
// (kChanBlock * ldb elements: the block's tap rows) and rows (nrow elements: staged frame rows) are the calling
// thread's scratch (slots 4 and 5; the callers of the transforms hold slots 0-3, the offset tables slot 6).
template <typename T, typename F>
void for_channel_blocks(int64_t C, int64_t work, int64_t ldb, int64_t nrow, F&& f) {
  const int64_t nblk = (C + kChanBlock - 1) / kChanBlock;
  const int nt = fused_threads(work);
#pragma omp parallel num_threads(nt) if (nt > 1)
  {
    T* blk = fused_scratch<T>(4, kChanBlock * ldb);
    T* rows = fused_scratch<T>(5, nrow);
#pragma omp for schedule(static)
    for (int64_t cb = 0; cb < nblk; ++cb) {
      const int64_t c0 = cb * kChanBlock;
      f(c0, C - c0 < kChanBlock ? C - c0 : kChanBlock, blk, rows);
    }
  }
}

// V[i][ci, b * nT + j] = sum_k BT[i][k] xpad[b0 + b, ci, base_j + k d]. The staged rows are the padded input
// (replicate/zero frames on the left, zeros on the right), so the gather needs no bounds checks.
template <typename T, int M>
void input_transform(T* V, const T* inp, const Conv1dShape& s, const Geo& g, int64_t b0, int64_t nb) {
  using W = Wino<M>;
  const int64_t L = g.To + (W::A - 1) * g.d, ldp = W::A * g.N;  // L: padded frames any tile touches
  const int64_t nl = g.padL < L ? g.padL : L, nx = L - nl < s.T ? L - nl : s.T;
  int32_t* tap = fused_scratch<int32_t>(6, W::A * g.N);
  tap_offsets(tap, W::A, M, g, nb, L, g.N);
  for_channel_blocks<T>(s.Cin, W::A * s.Cin * g.N, ldp, kChanBlock * nb * L, [&](int64_t c0, int64_t cn, T* P, T* xs) {
    stage_input_rows(xs, inp, s, b0, nb, c0, cn, L, nl, nx);
    for (int64_t cl = 0; cl < cn; ++cl) {
      gather_taps<T, W::A>(P + cl * ldp, xs + cl * nb * L, tap, g.N);
      combine_rows<T, W::A, W::A, false>(V + (c0 + cl) * g.N, s.Cin * g.N, P + cl * ldp, g.N, g.N, W::BT);
    }
  });
}

// dinp[b0 + b, ci, :] = fold(sum over tiles of BT^T dV[:][ci, b * nT + j] placed at base_j + k d): the tap rows
// are added into zeroed staged rows (k outer, so every frame sums its terms in a fixed order), then copied out.
template <typename T, int M>
void input_transform_backward(T* dinp, const T* dV, const Conv1dShape& s, const Geo& g, int64_t b0, int64_t nb) {
  using W = Wino<M>;
  const int64_t L = g.To + (W::A - 1) * g.d, ldp = W::A * g.N;  // L: padded frames any tile touches (>= T + padL)
  int32_t* tap = fused_scratch<int32_t>(6, W::A * g.N);
  tap_offsets(tap, W::A, M, g, nb, L, g.N);
  for_channel_blocks<T>(s.Cin, W::A * s.Cin * g.N, ldp, kChanBlock * nb * L, [&](int64_t c0, int64_t cn, T* P, T* bs) {
    for (int64_t cl = 0; cl < cn; ++cl) {
      T* p = P + cl * ldp;
      T* buf = bs + cl * nb * L;
      combine_rows<T, W::A, W::A, true>(p, g.N, dV + (c0 + cl) * g.N, s.Cin * g.N, g.N, W::BT);
      for (int64_t q = 0; q < nb * L; ++q) buf[q] = 0;
      scatter_add_taps<T, W::A>(buf, p, tap, g.N);
    }
    for (int64_t b = 0; b < nb; ++b)
      for (int64_t cl = 0; cl < cn; ++cl) {
        const T* buf = bs + (cl * nb + b) * L;
        T* dx = dinp + ((b0 + b) * s.Cin + c0 + cl) * s.T;
        for (int64_t t = 0; t < s.T; ++t) dx[t] = buf[g.padL + t];
        if (s.causal)
          for (int64_t p = 0; p < g.padL; ++p) dx[0] += buf[p];
      }
  });
}

// out[b0 + b, c0 + cl, t] = Y[cl][src[t] + b * nT] + bias[c0 + cl] for t < To.
template <typename T>
[[gnu::noinline]] void gather_output_rows(T* __restrict out, const T* __restrict Y, int64_t ldy,
                                          const int32_t* __restrict src, const T* bias, const Conv1dShape& s,
                                          const Geo& g, int64_t b0, int64_t nb, int64_t c0, int64_t cn) {
  for (int64_t b = 0; b < nb; ++b)
    for (int64_t cl = 0; cl < cn; ++cl) {
      const T* yb = Y + cl * ldy + b * g.nT;
      const T bv = bias ? bias[c0 + cl] : (T)0;
      T* y = out + ((b0 + b) * s.Cout + c0 + cl) * g.To;
      for (int64_t t = 0; t < g.To; ++t) y[t] = yb[src[t]] + bv;
    }
}

// out[b0 + b, co, base_j + r d] = bias[co] + sum_i AT[r][i] Mx[i][co, b * nT + j] for the frames below To: each
// frame t of a sample reads its tile's row r at src[t] = r * N + j (the outputs at or past To are dropped).
template <typename T, int M>
void output_transform(T* out, const T* Mx, const T* bias, const Conv1dShape& s, const Geo& g, int64_t b0,
                      int64_t nb) {
  using W = Wino<M>;
  const int64_t ldp = M * g.N;
  int32_t* src = fused_scratch<int32_t>(6, g.To);
  for (int64_t j = 0; j < g.nT; ++j) {
    const int64_t base = tile_base(j, M, g.d);
    for (int r = 0; r < M; ++r)
      if (base + r * g.d < g.To) src[base + r * g.d] = (int32_t)(r * g.N + j);
  }
  for_channel_blocks<T>(s.Cout, W::A * s.Cout * g.N, ldp, 0, [&](int64_t c0, int64_t cn, T* Y, T*) {
    for (int64_t cl = 0; cl < cn; ++cl)
      combine_rows<T, M, W::A, false>(Y + cl * ldp, g.N, Mx + (c0 + cl) * g.N, s.Cout * g.N, g.N, W::AT);
    gather_output_rows(out, Y, ldp, src, bias, s, g, b0, nb, c0, cn);
  });
}

// dM[i][co, b * nT + j] = sum_r AT[r][i] dy[b0 + b, co, base_j + r d] (0 for frames at or past To): the dy rows
// are staged with a zero tail up to Lo, then gathered like the input.
template <typename T, int M>
void output_transform_backward(T* dM, const T* dout, const Conv1dShape& s, const Geo& g, int64_t b0, int64_t nb) {
  using W = Wino<M>;
  const int64_t Lo = M * g.d * ((g.nT + g.d - 1) / g.d), ldp = M * g.N;  // Lo: frames the tiles cover (>= To)
  int32_t* tap = fused_scratch<int32_t>(6, M * g.N);
  tap_offsets(tap, M, M, g, nb, Lo, g.N);
  for_channel_blocks<T>(s.Cout, W::A * s.Cout * g.N, ldp, kChanBlock * nb * Lo, [&](int64_t c0, int64_t cn, T* D, T* ds) {
    for (int64_t b = 0; b < nb; ++b)
      for (int64_t cl = 0; cl < cn; ++cl) {
        const T* dy = dout + ((b0 + b) * s.Cout + c0 + cl) * g.To;
        T* row = ds + (cl * nb + b) * Lo;
        for (int64_t t = 0; t < g.To; ++t) row[t] = dy[t];
        for (int64_t t = g.To; t < Lo; ++t) row[t] = 0;  // frames past To: zero gradient
      }
    for (int64_t cl = 0; cl < cn; ++cl) {
      gather_taps<T, M>(D + cl * ldp, ds + cl * nb * Lo, tap, g.N);
      combine_rows<T, W::A, M, true>(dM + (c0 + cl) * g.N, s.Cout * g.N, D + cl * ldp, g.N, g.N, W::AT);
    }
  });
}

template <typename T, int M>
void forward_m(T* out, const T* inp, const T* weight, const T* bias, const Conv1dShape& s) {
  constexpr int A = Wino<M>::A;
  Geo g{s.out_len(), 0, s.dilation, s.pad_left(), 0};
  g.nT = tiles_per_sample(g.To, g.d, M);
  const int64_t NB = chunk_samples(s, A, g.nT), CC = s.Cout * s.Cin;
  T* U = fused_scratch<T>(2, A * CC);
  T* V = fused_scratch<T>(0, A * s.Cin * NB * g.nT);
  T* Mx = fused_scratch<T>(1, A * s.Cout * NB * g.nT);
  weight_transform<T, M>(U, weight, s);
  for (int64_t b0 = 0; b0 < s.B; b0 += NB) {
    const int64_t nb = s.B - b0 < NB ? s.B - b0 : NB;
    g.N = nb * g.nT;
    input_transform<T, M>(V, inp, s, g, b0, nb);
    gemm_batched(false, false, A, s.Cout, g.N, s.Cin, (T)1, U, s.Cin, CC, V, g.N, s.Cin * g.N, (T)0, Mx, g.N,
                 s.Cout * g.N);
    output_transform<T, M>(out, Mx, bias, s, g, b0, nb);
  }
}

template <typename T, int M>
void backward_m(T* dinp, T* dweight, T* dbias, const T* dout, const T* inp, const T* weight, const Conv1dShape& s) {
  constexpr int A = Wino<M>::A;
  Geo g{s.out_len(), 0, s.dilation, s.pad_left(), 0};
  g.nT = tiles_per_sample(g.To, g.d, M);
  const int64_t NB = chunk_samples(s, A, g.nT), CC = s.Cout * s.Cin;
  if (dbias) {
    const int nt = fused_threads(s.B * s.Cout * g.To);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
    for (int64_t co = 0; co < s.Cout; ++co) {
      T part[16] = {};  // same order for any thread count
      for (int64_t b = 0; b < s.B; ++b) add_to_partials16(part, dout + (b * s.Cout + co) * g.To, g.To);
      dbias[co] += sum_partials16(part);
    }
  }
  if (!dweight && !dinp) return;
  T* U = fused_scratch<T>(2, A * CC);
  T* dU = dweight ? fused_scratch<T>(3, A * CC) : nullptr;
  T* V = fused_scratch<T>(0, A * s.Cin * NB * g.nT);  // V, then dV
  T* dM = fused_scratch<T>(1, A * s.Cout * NB * g.nT);
  if (dinp) weight_transform<T, M>(U, weight, s);
  for (int64_t b0 = 0; b0 < s.B; b0 += NB) {
    const int64_t nb = s.B - b0 < NB ? s.B - b0 : NB;
    g.N = nb * g.nT;
    output_transform_backward<T, M>(dM, dout, s, g, b0, nb);
    if (dweight) {
      input_transform<T, M>(V, inp, s, g, b0, nb);
      gemm_batched(false, true, A, s.Cout, s.Cin, g.N, (T)1, dM, g.N, s.Cout * g.N, V, g.N, s.Cin * g.N,
                   b0 == 0 ? (T)0 : (T)1, dU, s.Cin, CC);
    }
    if (dinp) {
      gemm_batched(true, false, A, s.Cin, g.N, s.Cout, (T)1, U, s.Cin, CC, dM, g.N, s.Cout * g.N, (T)0, V, g.N,
                   s.Cin * g.N);
      input_transform_backward<T, M>(dinp, V, s, g, b0, nb);
    }
  }
  if (dweight) weight_transform_backward<T, M>(dweight, dU, s);
}

}  // namespace

int conv1d_winograd_tile(const Conv1dShape& s) {
  const int64_t To = s.out_len();
  if (s.K != 3 || s.stride != 1 || s.Cin < 8 || s.Cout < 8) return 0;
  const int64_t c2 = 4 * tiles_per_sample(To, s.dilation, 2), c4 = 6 * tiles_per_sample(To, s.dilation, 4);
  const bool f4 = !s.causal || !s.exact_causal;  // exactly causal: F(2, 3) only (see the header)
  const int m = f4 && c4 <= c2 ? 4 : 2;
  const int64_t cost = m == 4 ? c4 : c2;
  return 10 * cost <= 8 * 3 * To ? m : 0;  // pays only below 80% of im2col's 3 * To multiply-adds per channel pair
}

template <typename T>
void conv1d_winograd_forward(T* out, const T* inp, const T* weight, const T* bias, const Conv1dShape& s, int m) {
  const char* op = "conv1d_winograd_forward";
  s.out_len();
  check_shape(op, s);
  if (s.B == 0) return;
  check_ptr(op, "out", out);
  check_ptr(op, "inp", inp);
  check_ptr(op, "weight", weight);
  if (pick_tile(s, m) == 2)
    forward_m<T, 2>(out, inp, weight, bias, s);
  else
    forward_m<T, 4>(out, inp, weight, bias, s);
}

template <typename T>
void conv1d_winograd_backward(T* dinp, T* dweight, T* dbias, const T* dout, const T* inp, const T* weight,
                              const Conv1dShape& s, int m) {
  const char* op = "conv1d_winograd_backward";
  s.out_len();
  check_shape(op, s);
  if (s.B == 0) return;
  check_ptr(op, "dout", dout);
  if (dweight) check_ptr(op, "inp", inp);
  if (dinp) check_ptr(op, "weight", weight);
  if (pick_tile(s, m) == 2)
    backward_m<T, 2>(dinp, dweight, dbias, dout, inp, weight, s);
  else
    backward_m<T, 4>(dinp, dweight, dbias, dout, inp, weight, s);
}

template void conv1d_winograd_forward<float>(float*, const float*, const float*, const float*, const Conv1dShape&,
                                             int);
template void conv1d_winograd_forward<double>(double*, const double*, const double*, const double*,
                                              const Conv1dShape&, int);
template void conv1d_winograd_backward<float>(float*, float*, float*, const float*, const float*, const float*,
                                              const Conv1dShape&, int);
template void conv1d_winograd_backward<double>(double*, double*, double*, const double*, const double*,
                                               const double*, const Conv1dShape&, int);

}  // namespace t2m::fused
