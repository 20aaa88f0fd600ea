// upsample_nearest1d.h — nearest-neighbour upsampling along time by an integer factor (the VBB decoder's x2).
// out[b, c, t] = inp[b, c, t / scale]. Backward writes dinp (=): the sum of the `scale` output grads of each
// input frame. Errors: t2m::Error for N < 0, T < 1, scale < 1, null pointers.
#pragma once
#include <cstdint>

namespace t2m::fused {

// inp (N, T) with N = B*C rows; out (N, T*scale).
template <typename T>
void upsample_nearest1d_forward(T* out, const T* inp, int64_t N, int64_t Tlen, int64_t scale);
// dout (N, T*scale); dinp (N, T).
template <typename T>
void upsample_nearest1d_backward(T* dinp, const T* dout, int64_t N, int64_t Tlen, int64_t scale);

}  // namespace t2m::fused
