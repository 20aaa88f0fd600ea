// ops_conv.h — differentiable 1-D convolution and nearest upsampling over channel-first sequences, backed by the
// fused kernels (tensor/fused/conv1d.h, upsample_nearest1d.h). float32 and float64.
//
// conv1d(x, weight, bias, stride, dilation, padding):
//   x (B, Cin, T), weight (Cout, Cin, K), bias (Cout) or undefined  ->  out (B, Cout, To) with
//   To = floor((T + left + right - dilation*(K-1) - 1) / stride) + 1   (groups = 1).
//   Padding::zeros(left, right): zero frames on each side (symmetric padding goes straight to the kernel;
//     asymmetric padding is an explicit differentiable zero-pad step first).
//   Padding::causal(): (K-1)*dilation copies of frame 0 on the left, none on the right (the VBB's causal
//     replicate padding, straight to the kernel); the padding's gradient flows into frame 0.
//   Padding::causal(left): `left` copies of frame 0 instead (an explicit differentiable replicate step, then an
//     unpadded conv), e.g. the anchor's strided causal conv pads (K-1)*dilation + 1 - stride so that output t
//     sees inputs < (t+1)*stride.
//   Backward: dx = col2im(W^T g), dW += g col^T, db = sum over (B, To) of g (one GEMM each on the whole batch).
// upsample_nearest1d(x, scale): x (B, C, T) -> (B, C, T*scale), out[b, c, t] = x[b, c, t / scale];
//   the gradient of each input frame is the sum of its `scale` output gradients.
// Inputs of any strides are accepted (copied to contiguous once when needed).
// Errors (t2m::Error, message starts with the op name and names the shapes): x not 3-D, weight not 3-D,
// Cin mismatch, bias not (Cout), mixed/non-float dtypes, stride/dilation/scale < 1, negative padding, To < 1.
#pragma once
#include <cstdint>

#include "autograd/variable.h"

namespace t2m::ag {

struct Conv1dPadding {
  enum class Mode : uint8_t { zeros, causal_replicate };
  Mode mode = Mode::zeros;
  int64_t left = 0, right = 0;  // zeros: zero frames per side; causal: replicated frames on the left
                                // (left < 0: (K-1)*dilation), right unused
  bool exact = true;            // causal: fused::Conv1dShape::exact_causal (false: rounding may see later frames)

  static Conv1dPadding zeros(int64_t left, int64_t right) { return {Mode::zeros, left, right, true}; }
  static Conv1dPadding same_zeros(int64_t pad) { return {Mode::zeros, pad, pad, true}; }
  static Conv1dPadding causal(int64_t left = -1, bool exact = true) {
    return {Mode::causal_replicate, left, 0, exact};
  }
};

Variable conv1d(const Variable& x, const Variable& weight, const Variable& bias, int64_t stride = 1,
                int64_t dilation = 1, Conv1dPadding padding = {});

Variable upsample_nearest1d(const Variable& x, int64_t scale);

}  // namespace t2m::ag
