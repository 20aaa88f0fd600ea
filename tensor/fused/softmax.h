// softmax.h — softmax and log-softmax over the last dimension, max-subtracted.
// Backward writes dinp (=) from the saved forward output. float uses the vectorised exp of fast_exp.h.
// Errors: t2m::Error for N < 0, C < 1, null pointers.
#pragma once
#include <cstdint>

namespace t2m::fused {

// inp (N, C); out (N, C) = exp(x - max) / sum exp(x - max). out may alias inp.
template <typename T>
void softmax_forward(T* out, const T* inp, int64_t N, int64_t C);
// dout, out (N, C); dinp (N, C) = out * (dout - sum(dout * out)). dinp may alias dout.
template <typename T>
void softmax_backward(T* dinp, const T* dout, const T* out, int64_t N, int64_t C);

// inp (N, C); out (N, C) = x - max - log(sum exp(x - max)). out may alias inp.
template <typename T>
void log_softmax_forward(T* out, const T* inp, int64_t N, int64_t C);
// dout, out (N, C); dinp (N, C) = dout - exp(out) * sum(dout). dinp may alias dout.
template <typename T>
void log_softmax_backward(T* dinp, const T* dout, const T* out, int64_t N, int64_t C);

}  // namespace t2m::fused
