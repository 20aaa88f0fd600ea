// conv1d.h — 1-D convolution over channel-first sequences (the VBB conv VAE), im2col + t2m::gemm.
//
// inp (B, Cin, T), weight (Cout, Cin, K), bias (Cout) or null, out (B, Cout, To) with
//   To = floor((T + padL + padR - dilation*(K-1) - 1) / stride) + 1.
// Padding: causal == true pads frames on the left by REPLICATING frame 0 (padL = (K-1)*dilation, or causal_left
// when that is >= 0, e.g. (K-1)*dilation + 1 - stride for a strided causal conv; padR = 0; `pad` must be 0);
// otherwise `pad` zero frames on both sides (padL = padR = pad).
// Backward writes dinp (=) and accumulates dweight/dbias (+=); the replicate padding's gradient flows into frame 0.
// The GEMMs work on chunks of nb samples at once (the column matrix is (Cin*K, nb*To), nb as large as keeps it
// within 4 MB of float, at least 1, the whole batch for small shapes); dweight/dbias accumulate chunk by chunk.
// out, dout (and for a K=1, stride=1, unpadded convolution also inp and dinp) are read and written in place as
// (C, nb*To) matrices in per-sample column segments (gemm_segmented), without relayout copies.
// Scratch (thread-local, scratch.h): slot 0 col (Cin*K * nb*To) elements; none for the K=1, stride=1, pad=0 case.
// Algorithm: k = 3, stride 1 convolutions whose shape pays for it run Winograd F(m, 3) instead
// (conv1d_winograd.h: 1/3 to 1/2 fewer multiply-adds); Conv1dShape::algo forces one path (tests, benchmarks).
// Deterministic for a fixed thread count (every reduction has a fixed order).
// Errors: t2m::Error for sizes < 1 (B may be 0), stride/dilation < 1, pad < 0, causal with pad != 0, causal_left
// below -1 or set without causal, To < 1,
// null required pointers.
#pragma once
#include <cstdint>

namespace t2m::fused {

enum class Conv1dAlgo { automatic, im2col, winograd };

struct Conv1dShape {
  int64_t B = 1, Cin = 1, Cout = 1, T = 1, K = 1;
  int64_t stride = 1, dilation = 1, pad = 0;
  bool causal = false;
  int64_t causal_left = -1;  // causal only: frames replicated on the left; -1: (K-1)*dilation
  // causal only: true keeps every output independent of later frames even in rounding (Winograd F(2, 3) at most);
  // false also allows F(4, 3), whose outputs carry ~1e-7 relative rounding from up to 3 later frames of their tile.
  bool exact_causal = true;
  Conv1dAlgo algo = Conv1dAlgo::automatic;  // automatic: Winograd where conv1d_winograd_tile(s) != 0
  int64_t pad_left() const { return causal ? (causal_left >= 0 ? causal_left : (K - 1) * dilation) : pad; }
  int64_t pad_right() const { return causal ? 0 : pad; }
  int64_t out_len() const;  // To; throws Error when the configuration is invalid or To < 1
};

// inp (B, Cin, T), weight (Cout, Cin, K), bias (Cout) or null; out (B, Cout, To).
template <typename T>
void conv1d_forward(T* out, const T* inp, const T* weight, const T* bias, const Conv1dShape& s);

// dout (B, Cout, To), inp (B, Cin, T), weight (Cout, Cin, K). dinp (B, Cin, T) written (may be null to skip);
// dweight (Cout, Cin, K) and dbias (Cout) accumulated (+=), each may be null.
template <typename T>
void conv1d_backward(T* dinp, T* dweight, T* dbias, const T* dout, const T* inp, const T* weight,
                     const Conv1dShape& s);

// FLOPs of one forward (2 * B * Cout * Cin * K * To); the backward with dinp and dweight is twice that.
double conv1d_forward_flops(const Conv1dShape& s);

}  // namespace t2m::fused
