// conv1d_winograd.h — k = 3, stride 1 conv1d (any dilation, causal replicate or zero padding) by Winograd's
// minimal filtering F(m, 3), m = 2 or 4 output frames per tile, one batched GEMM per transformed point.
// Same contract as conv1d_forward / conv1d_backward (conv1d.h): same shapes, padding rules, dinp written,
// dweight/dbias accumulated. Counted in multiply-adds per output, im2col + GEMM does 3 * Cin per output frame;
// F(m, 3) does (m + 2) * Cin per tile of m frames, i.e. 2 * Cin (m = 2) or 1.5 * Cin (m = 4): 1/3 or 1/2 fewer.
//
// Tiles follow the dilation: a tile's m outputs are frames base, base + d, ..., base + (m-1) d and it reads the
// m + 2 padded input frames base + i d. Bases: j -> m d (j / d) + j % d, as many as start inside [0, To); a tile's
// outputs at or past To are computed and dropped (that waste is why short sequences with large dilations keep the
// im2col path, see conv1d_winograd_tile).
// Causality: in F(2, 3) output 0 of a tile is built only from the transformed rows that do not contain the
// tile's last input frame, so a causal conv's output never depends on a later frame, not even by rounding. In
// F(4, 3) every output of a tile mixes all 6 input frames (the later ones cancel exactly in real arithmetic,
// not in float: ~1e-7 relative leaks), so the automatic choice uses F(4, 3) only for non-causal convs and for
// causal ones marked Conv1dShape::exact_causal = false (the VBB's residual blocks, whose GroupNorm sees every frame).
// Numerics: F(2, 3) uses the points 0, 1, -1 (coefficients 1 and 1/2, as accurate as the direct sum);
// F(4, 3) the points 0, 1, -1, 2, -2 (coefficients up to 5 and 1/24: float error about 10x the direct sum's,
// ~1e-6 relative on unit-scale data with 256 channels).
#pragma once
#include "tensor/fused/conv1d.h"

namespace t2m::fused {

// Tile size the automatic dispatch would use for s: 2 or 4 (4 never for exact_causal causal convs) when K == 3, stride == 1,
// Cin, Cout >= 8 and F(m, 3) needs at most 80% of im2col's multiply-adds (counting dropped outputs); 0 when
// Winograd does not apply or does not pay.
int conv1d_winograd_tile(const Conv1dShape& s);

// F(m, 3), m = 2 or 4 (0 = pick with conv1d_winograd_tile, then 4 if that says 0). Throws Error unless
// K == 3 and stride == 1 (and for the configurations conv1d_forward rejects).
template <typename T>
void conv1d_winograd_forward(T* out, const T* inp, const T* weight, const T* bias, const Conv1dShape& s, int m = 0);

template <typename T>
void conv1d_winograd_backward(T* dinp, T* dweight, T* dbias, const T* dout, const T* inp, const T* weight,
                              const Conv1dShape& s, int m = 0);

}  // namespace t2m::fused
