// conv1d.h — the Conv1d module over channel-first sequences (ag::conv1d; groups = 1).
//
// Conv1d(cin, cout, k, opts, gen): parameters "weight" (cout, cin, k) and, with opts.bias, "bias" (cout), both
// drawn from U(-1/sqrt(cin*k), 1/sqrt(cin*k)) (PyTorch's default), weight first.
// forward: x (B, cin, T) -> (B, cout, To).
// Padding modes:
//   Conv1dPad::zeros  — opts.pad zero frames on both sides (PyTorch's padding=pad).
//   Conv1dPad::causal — replicate frame 0 on the left only, (k-1)*dilation + 1 - stride frames (at least 0), the
//     anchor's CausalConv1d (../shared/anchor/torch_ref.py): output t sees only inputs < (t+1)*stride, and with
//     stride 1 that is the usual (k-1)*dilation (the fused kernel's own causal path). opts.pad must be 0.
// Errors: sizes/stride/dilation < 1, negative pad, pad with causal; shape errors from ag::conv1d at forward.
#pragma once
#include <cstdint>

#include "autograd/ops_conv.h"
#include "autograd/variable.h"
#include "nn/module.h"
#include "tensor/rng.h"

namespace t2m::nn {

enum class Conv1dPad : uint8_t { zeros, causal };

struct Conv1dOptions {
  int64_t stride = 1;
  int64_t dilation = 1;
  Conv1dPad mode = Conv1dPad::zeros;
  int64_t pad = 0;  // zeros mode: frames per side
  bool bias = true;
  bool exact_causal = true;  // causal: false lets rounding see later frames (faster Winograd F(4, 3), ops_conv.h)
};

class Conv1d : public Module {
 public:
  Conv1d(int64_t cin, int64_t cout, int64_t k, const Conv1dOptions& opts, Generator& gen);
  ag::Variable forward(const ag::Variable& x) const;
  ag::Variable operator()(const ag::Variable& x) const { return forward(x); }

  const ag::Variable& weight() const { return weight_; }
  const ag::Variable& bias() const { return bias_; }  // undefined without bias
  const Conv1dOptions& options() const { return opts_; }
  int64_t in_channels() const { return cin_; }
  int64_t out_channels() const { return cout_; }
  int64_t kernel_size() const { return k_; }
  ag::Conv1dPadding padding() const { return padding_; }  // what forward passes to ag::conv1d

 private:
  int64_t cin_, cout_, k_;
  Conv1dOptions opts_;
  ag::Conv1dPadding padding_;
  ag::Variable weight_, bias_;
};

}  // namespace t2m::nn
