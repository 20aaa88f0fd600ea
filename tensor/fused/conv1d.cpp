// conv1d.cpp — k3 stride-1 shapes that pay go to Winograd (conv1d_winograd.cpp); the others, per chunk of samples
// (chunk_samples: the chunk's column matrix stays in cache), im2col into col (Cin*K, nb*To), column b*To + to, then
//   forward:  out (Cout, nb*To) = W (Cout, Cin*K) @ col;  out[b, co, to] += bias[co]
//   backward: dbias[co] += sums of dout[b, co, :];  dW (Cout, Cin*K) += dout @ col^T
//             dcol (Cin*K, nb*To) = W^T @ dout;  dinp = col2im(dcol)
// where out and dout are read and written in place as (Cout, nb*To) matrices whose columns lie in segments of To
// (gemm_segmented: sample b's (Cout, To) slice is columns [b*To, b*To + To)). A k1 stride-1 unpadded convolution
// skips im2col too (col would be a copy of inp): inp, and dinp, are segmented matrices (Cin, nb*T) as well.
#include "tensor/fused/conv1d.h"

#include <string>
#include <utility>

#include "tensor/fused/conv1d_winograd.h"
#include "tensor/fused/kernel_util.h"
#include "tensor/fused/scratch.h"
#include "tensor/gemm.h"

namespace t2m::fused {

int64_t Conv1dShape::out_len() const {
  const char* op = "conv1d";
  check_dim(op, "B", B, 0);
  check_dim(op, "Cin", Cin, 1);
  check_dim(op, "Cout", Cout, 1);
  check_dim(op, "T", T, 1);
  check_dim(op, "K", K, 1);
  check_dim(op, "stride", stride, 1);
  check_dim(op, "dilation", dilation, 1);
  check_dim(op, "pad", pad, 0);
  if (causal && pad != 0)
    throw Error("conv1d: causal padding is (K-1)*dilation on the left; pad must be 0, got " + std::to_string(pad));
  if (causal_left < -1 || (!causal && causal_left != -1))
    throw Error("conv1d: causal_left must be -1 or, for a causal conv, >= 0; got " + std::to_string(causal_left) +
                (causal ? "" : " without causal"));
  const int64_t span = T + pad_left() + pad_right() - dilation * (K - 1) - 1;
  if (span < 0)
    throw Error("conv1d: kernel span " + std::to_string(dilation * (K - 1) + 1) + " exceeds padded length " +
                std::to_string(T + pad_left() + pad_right()) + " (T=" + std::to_string(T) + ")");
  return span / stride + 1;
}

double conv1d_forward_flops(const Conv1dShape& s) {
  return 2.0 * (double)s.B * (double)s.Cout * (double)s.Cin * (double)s.K * (double)s.out_len();
}

namespace {

// Outputs `to` whose input frame to*stride + off lies in [0, T): the range [lo, hi). Below lo the frame is left
// of the sequence (padding), from hi on right of it.
std::pair<int64_t, int64_t> valid_outputs(int64_t off, const Conv1dShape& s, int64_t To) {
  int64_t lo = off >= 0 ? 0 : (-off + s.stride - 1) / s.stride;
  int64_t hi = (s.T - 1 - off) < 0 ? 0 : (s.T - 1 - off) / s.stride + 1;
  lo = lo < To ? lo : To;
  hi = hi < lo ? lo : (hi > To ? To : hi);
  return {lo, hi};
}

// Samples per chunk: the column matrix of one chunk (Cin*K x nb*To floats) stays within kColChunkElems so that
// im2col's output is still in cache (L3) when the GEMM packs it, and col2im reads dcol from cache; at least one
// sample. Depends on the shape only, so the summation order (and the result bits) is fixed per thread count.
constexpr int64_t kColChunkElems = int64_t{1} << 20;  // 4 MB of float

// Winograd tile for s (0: im2col), after the configuration checks of out_len().
int winograd_tile(const Conv1dShape& s) {
  switch (s.algo) {
    case Conv1dAlgo::im2col: return 0;
    case Conv1dAlgo::winograd: return conv1d_winograd_tile(s) ? conv1d_winograd_tile(s) : 4;
    default: return conv1d_winograd_tile(s);
  }
}

// k = 1, stride 1, no padding: the column matrix would be inp itself, sample by sample.
bool reads_input_as_columns(const Conv1dShape& s) {
  return s.K == 1 && s.stride == 1 && s.pad_left() == 0 && s.pad_right() == 0;
}

// A (B, C, L) tensor's samples side by side as one (C, B*L) matrix (row stride L): column b*L + l.
GemmColumns sample_columns(int64_t L, int64_t C) { return GemmColumns{L, C * L}; }

int64_t chunk_samples(const Conv1dShape& s, int64_t To) {
  const int64_t per = s.Cin * s.K * To;
  const int64_t nb = kColChunkElems / (per > 0 ? per : 1);
  return nb < 1 ? 1 : (nb > s.B ? s.B : nb);
}

// Samples [b0, b0 + nb): col[(ci*K + k), (b-b0)*To + to] = x_padded[b, ci, to*stride + k*dilation - padL].
template <typename T>
void im2col(T* col, const T* inp, const Conv1dShape& s, int64_t To, int64_t b0, int64_t nb) {
  const int64_t N = nb * To, padL = s.pad_left();
  const int nt = fused_threads(s.Cin * s.K * N);
#pragma omp parallel for collapse(2) num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t ci = 0; ci < s.Cin; ++ci)
    for (int64_t k = 0; k < s.K; ++k) {
      T* row = col + (ci * s.K + k) * N;
      const int64_t off = k * s.dilation - padL;
      const auto [lo, hi] = valid_outputs(off, s, To);
      for (int64_t b = 0; b < nb; ++b) {
        const T* x = inp + ((b0 + b) * s.Cin + ci) * s.T;
        T* dst = row + b * To;
        const T left = s.causal ? x[0] : (T)0;
        for (int64_t to = 0; to < lo; ++to) dst[to] = left;
        if (s.stride == 1) {
          for (int64_t to = lo; to < hi; ++to) dst[to] = x[to + off];
        } else {
          for (int64_t to = lo; to < hi; ++to) dst[to] = x[to * s.stride + off];
        }
        for (int64_t to = hi; to < To; ++to) dst[to] = (T)0;
      }
    }
}

// Samples [b0, b0 + nb): dinp[b, ci, t] = sum of dcol entries that im2col read from (b, ci, t); the causal left
// pad adds into t = 0. ci outer, b inner: the K rows of dcol that input channel ci reads are walked front to back
// (sequential streams) and only the dinp rows jump.
template <typename T>
void col2im(T* dinp, const T* dcol, const Conv1dShape& s, int64_t To, int64_t b0, int64_t nb) {
  const int64_t N = nb * To, padL = s.pad_left();
  const int nt = fused_threads(s.Cin * s.K * N);
#pragma omp parallel for collapse(2) num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t ci = 0; ci < s.Cin; ++ci)
    for (int64_t b = 0; b < nb; ++b) {
      T* dx = dinp + ((b0 + b) * s.Cin + ci) * s.T;
      for (int64_t t = 0; t < s.T; ++t) dx[t] = 0;
      for (int64_t k = 0; k < s.K; ++k) {
        const T* src = dcol + (ci * s.K + k) * N + b * To;
        const int64_t off = k * s.dilation - padL;
        const auto [lo, hi] = valid_outputs(off, s, To);
        if (s.causal)
          for (int64_t to = 0; to < lo; ++to) dx[0] += src[to];
        if (s.stride == 1) {
          for (int64_t to = lo; to < hi; ++to) dx[to + off] += src[to];
        } else {
          for (int64_t to = lo; to < hi; ++to) dx[to * s.stride + off] += src[to];
        }
      }
    }
}

}  // namespace

template <typename T>
void conv1d_forward(T* out, const T* inp, const T* weight, const T* bias, const Conv1dShape& s) {
  const char* op = "conv1d_forward";
  const int64_t To = s.out_len();
  if (s.B == 0) return;
  check_ptr(op, "out", out);
  check_ptr(op, "inp", inp);
  check_ptr(op, "weight", weight);
  if (const int m = winograd_tile(s)) return conv1d_winograd_forward(out, inp, weight, bias, s, m);
  const int64_t CK = s.Cin * s.K, NB = chunk_samples(s, To);
  const bool k1 = reads_input_as_columns(s);
  T* col = k1 ? nullptr : fused_scratch<T>(0, CK * NB * To);
  for (int64_t b0 = 0; b0 < s.B; b0 += NB) {
    const int64_t nb = s.B - b0 < NB ? s.B - b0 : NB, N = nb * To;
    T* o = out + b0 * s.Cout * To;
    if (k1) {
      gemm_segmented(false, false, s.Cout, N, CK, (T)1, weight, CK, {}, inp + b0 * s.Cin * s.T, s.T,
                     sample_columns(s.T, s.Cin), (T)0, o, To, sample_columns(To, s.Cout));
    } else {
      im2col(col, inp, s, To, b0, nb);
      gemm_segmented(false, false, s.Cout, N, CK, (T)1, weight, CK, {}, col, N, {}, (T)0, o, To,
                     sample_columns(To, s.Cout));
    }
    if (!bias) continue;
    // After the product, not as its starting value: a bias joining before the last K block would round otherwise.
    const int nt = fused_threads(s.Cout * N);
#pragma omp parallel for collapse(2) num_threads(nt) schedule(static) if (nt > 1)
    for (int64_t b = 0; b < nb; ++b)
      for (int64_t co = 0; co < s.Cout; ++co) {
        T* dst = o + (b * s.Cout + co) * To;
        const T bv = bias[co];
        for (int64_t to = 0; to < To; ++to) dst[to] += bv;
      }
  }
}

template <typename T>
void conv1d_backward(T* dinp, T* dweight, T* dbias, const T* dout, const T* inp, const T* weight,
                     const Conv1dShape& s) {
  const char* op = "conv1d_backward";
  const int64_t To = s.out_len();
  if (s.B == 0) return;
  check_ptr(op, "dout", dout);
  if (dweight) check_ptr(op, "inp", inp);
  if (dinp) check_ptr(op, "weight", weight);
  if (const int m = winograd_tile(s))
    return conv1d_winograd_backward(dinp, dweight, dbias, dout, inp, weight, s, m);
  const int64_t CK = s.Cin * s.K, NB = chunk_samples(s, To);
  const bool k1 = reads_input_as_columns(s);
  T* col = k1 ? nullptr : fused_scratch<T>(0, CK * NB * To);
  const GemmColumns out_cols = sample_columns(To, s.Cout), in_cols = sample_columns(s.T, s.Cin);
  for (int64_t b0 = 0; b0 < s.B; b0 += NB) {
    const int64_t nb = s.B - b0 < NB ? s.B - b0 : NB, N = nb * To;
    const T* dO = dout + b0 * s.Cout * To;  // (Cout, N) in segments
    if (dbias) {
      const int nt = fused_threads(s.Cout * N);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
      for (int64_t co = 0; co < s.Cout; ++co) {
        T part[16] = {};  // 16 partial sums of the bias gradient: vectorisable, same order for any thread count
        for (int64_t b = 0; b < nb; ++b) add_to_partials16(part, dO + (b * s.Cout + co) * To, To);
        dbias[co] += sum_partials16(part);
      }
    }
    if (dweight) {
      if (k1) {
        gemm_segmented(false, true, s.Cout, CK, N, (T)1, dO, To, out_cols, inp + b0 * s.Cin * s.T, s.T, in_cols,
                       (T)1, dweight, CK, {});
      } else {
        im2col(col, inp, s, To, b0, nb);
        gemm_segmented(false, true, s.Cout, CK, N, (T)1, dO, To, out_cols, col, N, {}, (T)1, dweight, CK, {});
      }
    }
    if (!dinp) continue;
    if (k1) {
      gemm_segmented(true, false, CK, N, s.Cout, (T)1, weight, CK, {}, dO, To, out_cols, (T)0,
                     dinp + b0 * s.Cin * s.T, s.T, in_cols);
    } else {
      T* dcol = col;  // col is no longer needed
      gemm_segmented(true, false, CK, N, s.Cout, (T)1, weight, CK, {}, dO, To, out_cols, (T)0, dcol, N, {});
      col2im(dinp, dcol, s, To, b0, nb);
    }
  }
}

template void conv1d_forward<float>(float*, const float*, const float*, const float*, const Conv1dShape&);
template void conv1d_forward<double>(double*, const double*, const double*, const double*, const Conv1dShape&);
template void conv1d_backward<float>(float*, float*, float*, const float*, const float*, const float*,
                                     const Conv1dShape&);
template void conv1d_backward<double>(double*, double*, double*, const double*, const double*, const double*,
                                      const Conv1dShape&);

}  // namespace t2m::fused
