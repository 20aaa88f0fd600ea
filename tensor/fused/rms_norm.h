// rms_norm.h — RMSNorm over the last dimension (Zhang & Sennrich 2019), used for the QK-norm of the flow
// transformer. Conventions as in layer_norm.h: backward writes dinp (=), accumulates dweight (+=).
// Scratch: nthreads * C elements (parameter-gradient partials). Errors: t2m::Error for N < 0, C < 1, eps < 0,
// null required pointers.
#pragma once
#include <cstdint>

namespace t2m::fused {

// inp (N, C), weight (C) or null; out (N, C); rstd (N) saved for backward.
// y = x * rstd * weight, rstd = 1 / sqrt(mean(x^2) + eps).
template <typename T>
void rms_norm_forward(T* out, T* rstd, const T* inp, const T* weight, int64_t N, int64_t C, T eps);

// dout, inp (N, C); weight (C) or null; rstd (N). dinp (N, C) written; dweight (C) accumulated, may be null.
template <typename T>
void rms_norm_backward(T* dinp, T* dweight, const T* dout, const T* inp, const T* weight, const T* rstd, int64_t N,
                       int64_t C);


// One row of each (the loops of the two above, for kernels that normalise rows they gather themselves, such as
// attention_heads.h; the same compiled code, so the same bits). x, y, dy, dx (C); returns rstd. dweight (C)
// accumulated (may be null).
template <typename T>
T rms_norm_row_forward(T* y, const T* x, const T* weight, int64_t C, T eps);
template <typename T>
void rms_norm_row_backward(T* dx, T* dweight, const T* dy, const T* x, const T* weight, T rstd, int64_t C);

}  // namespace t2m::fused
