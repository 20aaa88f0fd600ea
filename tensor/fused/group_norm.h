// group_norm.h — GroupNorm (Wu & He 2018) over channel-first conv activations, affine per channel.
// Conventions as in layer_norm.h: backward writes dinp (=), accumulates dweight/dbias (+=).
// Statistics are taken over the Cg = C/G channels x T frames of each (batch, group).
// Scratch: nthreads * 2C elements (parameter-gradient partials).
// Errors: t2m::Error for B < 0, C/T/G < 1, C not divisible by G, eps < 0, null required pointers.
#pragma once
#include <cstdint>

namespace t2m::fused {

// inp (B, C, T), weight/bias (C) or null; out (B, C, T); mean/rstd (B, G) saved for backward. relu: out =
// max(norm, 0) as each row is written (y > 0 ? y : 0, so NaN and -0 give +0; the same bits as a ReLU pass after).
template <typename T>
void group_norm_forward(T* out, T* mean, T* rstd, const T* inp, const T* weight, const T* bias, int64_t B,
                        int64_t C, int64_t Tlen, int64_t G, T eps, bool relu = false);

// dout, inp (B, C, T); weight (C) or null; mean/rstd (B, G). dinp (B, C, T) written; dweight/dbias (C)
// accumulated, each may be null. relu: the forward ran with relu (bias (C) or null: the forward's bias); where
// its output was not > 0 the gradient is taken as 0 (GroupNorm -> ReLU backward in one pass). The output's sign
// is recomputed from inp, mean, rstd, weight and bias with the forward's operations (the same bits), rather than
// read back: one stream less.
template <typename T>
void group_norm_backward(T* dinp, T* dweight, T* dbias, const T* dout, const T* inp, const T* weight,
                         const T* mean, const T* rstd, int64_t B, int64_t C, int64_t Tlen, int64_t G,
                         bool relu = false, const T* bias = nullptr);

}  // namespace t2m::fused
