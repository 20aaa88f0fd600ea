// gelu_tanh.h — GELU, tanh approximation (Hendrycks & Gimpel 2016):
// y = 0.5 x (1 + tanh(sqrt(2/pi) (x + 0.044715 x^3))). Elementwise over n values; backward writes dinp (=).
// float uses the vectorised tanh of fast_exp.h (absolute error ~1e-7); on AVX-512 CPUs the loops run in zmm (2x
// faster, the same bits). Errors: t2m::Error for n < 0, null ptrs.
#pragma once
#include <cstdint>

namespace t2m::fused {

// inp (n); out (n). out may alias inp.
template <typename T>
void gelu_tanh_forward(T* out, const T* inp, int64_t n);
// dout, inp (n); dinp (n) = dout * gelu'(inp). dinp may alias dout.
template <typename T>
void gelu_tanh_backward(T* dinp, const T* dout, const T* inp, int64_t n);

}  // namespace t2m::fused
