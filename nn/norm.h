// norm.h — normalisation modules over the fused ops of autograd/ops_norm.h.
//
// LayerNorm(C, affine, eps, bias): over the last dim of x (..., C). With affine, "weight" (C) = 1 and, when bias
//   is on, "bias" (C) = 0 (PyTorch's init); without affine, no parameters.
// RMSNorm(C, affine, eps): over the last dim; with affine a "weight" (C) = 1.
// GroupNorm(groups, C, affine, eps): x (B, C, T); "weight" (C) = 1 and "bias" (C) = 0 with affine.
//   forward_relu(x) = relu(forward(x)) as one fused op (ag::group_norm_relu).
// Errors: C < 1, groups < 1 or C not divisible by groups at construction; shape errors from the ops at forward.
#pragma once
#include <cstdint>

#include "autograd/variable.h"
#include "nn/module.h"

namespace t2m::nn {

class LayerNorm : public Module {
 public:
  explicit LayerNorm(int64_t C, bool affine = true, double eps = 1e-5, bool bias = true);
  ag::Variable forward(const ag::Variable& x) const;
  ag::Variable operator()(const ag::Variable& x) const { return forward(x); }
  const ag::Variable& weight() const { return weight_; }  // undefined without affine
  const ag::Variable& bias() const { return bias_; }      // undefined without affine or bias
  int64_t channels() const { return C_; }

 private:
  int64_t C_;
  double eps_;
  ag::Variable weight_, bias_;
};

class RMSNorm : public Module {
 public:
  explicit RMSNorm(int64_t C, bool affine = true, double eps = 1e-6);
  ag::Variable forward(const ag::Variable& x) const;
  ag::Variable operator()(const ag::Variable& x) const { return forward(x); }
  const ag::Variable& weight() const { return weight_; }
  int64_t channels() const { return C_; }

 private:
  int64_t C_;
  double eps_;
  ag::Variable weight_;
};

class GroupNorm : public Module {
 public:
  GroupNorm(int64_t groups, int64_t C, bool affine = true, double eps = 1e-5);
  ag::Variable forward(const ag::Variable& x) const;
  ag::Variable forward_relu(const ag::Variable& x) const;
  ag::Variable operator()(const ag::Variable& x) const { return forward(x); }
  const ag::Variable& weight() const { return weight_; }
  const ag::Variable& bias() const { return bias_; }
  int64_t groups() const { return groups_; }
  int64_t channels() const { return C_; }

 private:
  int64_t groups_, C_;
  double eps_;
  ag::Variable weight_, bias_;
};

}  // namespace t2m::nn
