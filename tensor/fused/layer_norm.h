// layer_norm.h — LayerNorm over the last dimension (Ba et al. 2016), fused forward/backward.
//
// Conventions of every fused kernel (tensor/fused/*): raw contiguous row-major pointers; backward WRITES input
// gradients (=) and ACCUMULATES parameter gradients (+=); a parameter-gradient pointer may be null to skip it;
// rows are split across t2m::get_num_threads() OpenMP threads when the work exceeds t2m::kParallelGrain, and
// parameter-gradient partials are reduced per thread in a fixed order (bitwise deterministic per thread count).
// Scratch: parameter-gradient partials of nthreads * 2C elements in thread-local cached memory (scratch.h), and
// with tanh_out one row of C per thread (slot 1).
// Errors: t2m::Error for N < 0, C < 1, eps < 0 or a null required pointer.
#pragma once
#include <cstdint>

namespace t2m::fused {

// inp (N, C), weight/bias (C) or null for no affine (bias may be null alone); out (N, C);
// mean/rstd (N) saved for backward. y = (x - mean) * rstd * weight + bias, rstd = 1/sqrt(var + eps),
// var the biased (1/C) variance.
template <typename T>
void layer_norm_forward(T* out, T* mean, T* rstd, const T* inp, const T* weight, const T* bias, int64_t N,
                        int64_t C, T eps);

// dout, inp (N, C); weight (C) or null; mean/rstd (N) from the forward. dinp (N, C) written;
// dweight/dbias (C) accumulated (+=), each may be null. tanh_out (N, C) or null: the forward's output went on
// through tanh (tanh_out = tanh(out)) and dout is the gradient of tanh_out; each row of dout is then multiplied by
// 1 - tanh_out^2 first, in a row buffer (the tanh's backward without an (N, C) intermediate; the same bits).
template <typename T>
void layer_norm_backward(T* dinp, T* dweight, T* dbias, const T* dout, const T* inp, const T* weight,
                         const T* mean, const T* rstd, int64_t N, int64_t C, const T* tanh_out = nullptr);

}  // namespace t2m::fused
