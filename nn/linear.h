// linear.h — the fully connected layer y = x W^T + b (PyTorch nn.Linear semantics and default init).
//
// linear(x, weight, bias): the differentiable op. x (..., in), weight (out, in), bias (out) or undefined
//   -> y (..., out). One GEMM over all leading dims at once (x flattened to (N, in)); the bias is written into
//   the output first and the GEMM accumulates onto it (beta = 1), so there is no separate broadcast pass.
//   Backward: dx = g W (one GEMM), dW += g^T x (one GEMM), db = column sums of g. Inputs of any strides are
//   accepted (copied to contiguous once when needed). float32 and float64.
//   Errors (t2m::Error, message starts "linear:" and names the shapes): x with no dims, x's last dim != in,
//   weight not 2-D, bias not (out), non-float or mixed dtypes.
// linear_relu(x, weight, bias): relu(linear(x, weight, bias)) as one op, the same bits forward and backward: the
//   ReLU runs on each output tile as the GEMM stores it (no pass of its own, no pre-activation tensor kept), and
//   the backward masks the output gradient by y > 0 before the linear backward. Errors as linear ("linear_relu:").
//
// Linear(in, out, bias, gen): parameters "weight" (out, in) and "bias" (out) when bias is on, both drawn from
//   U(-1/sqrt(in), 1/sqrt(in)) (PyTorch's default), weight first, from the given Generator.
//   Errors: in < 1 or out < 1.
#pragma once
#include <cstdint>

#include "autograd/variable.h"
#include "nn/module.h"
#include "tensor/rng.h"

namespace t2m::nn {

ag::Variable linear(const ag::Variable& x, const ag::Variable& weight, const ag::Variable& bias);
ag::Variable linear_relu(const ag::Variable& x, const ag::Variable& weight, const ag::Variable& bias);

class Linear : public Module {
 public:
  Linear(int64_t in_features, int64_t out_features, bool bias, Generator& gen);
  ag::Variable forward(const ag::Variable& x) const;
  ag::Variable operator()(const ag::Variable& x) const { return forward(x); }
  ag::Variable forward_relu(const ag::Variable& x) const;  // relu(forward(x)), fused (linear_relu)

  int64_t in_features() const { return in_; }
  int64_t out_features() const { return out_; }
  const ag::Variable& weight() const { return weight_; }
  const ag::Variable& bias() const { return bias_; }  // undefined without bias

 private:
  int64_t in_, out_;
  ag::Variable weight_, bias_;
};

}  // namespace t2m::nn
