// ops_norm.h — differentiable normalisation layers, each one op backed by a fused kernel with its own backward
// (tensor/fused/layer_norm.h, rms_norm.h, group_norm.h). float32 and float64.
//
// layer_norm(x, weight, bias, eps): LayerNorm over the last dim (Ba et al. 2016).
//   x (..., C); weight, bias (C) or undefined (undefined weight = no scale, undefined bias = no shift).
//   y = (x - mean) / sqrt(var + eps) * weight + bias, var the biased (1/C) variance. out has x's shape.
// rms_norm(x, weight, eps): RMSNorm over the last dim (Zhang & Sennrich 2019).
//   x (..., C); weight (C) or undefined.  y = x / sqrt(mean(x^2) + eps) * weight.
// group_norm(x, groups, weight, bias, eps): GroupNorm (Wu & He 2018) over channel-first activations.
//   x (B, C, T) (or (B, C): T = 1); C divisible by groups; weight, bias (C) or undefined. Statistics over the
//   C/groups channels x T frames of each (batch, group).
// group_norm_relu(...) = relu(group_norm(...)) as one op: the ReLU is applied in place on the normalised output
//   and the backward takes the gradient as 0 where that output was not > 0 (its sign recomputed from x and the
//   saved statistics, tensor/fused/group_norm.h), so no ReLU tensor is kept for it (the VBB residual block's
//   GroupNorm -> ReLU). relu'(0) = 0 as in ag::relu.
//
// Inputs of any strides are accepted (copied to contiguous once when needed); outputs are fresh contiguous
// tensors. The node keeps the contiguous input, the per-row mean/rstd and the weight (group_norm_relu also the
// bias, for the output's sign).
// Errors (t2m::Error, message starts with the op name and names the shapes): non-float or mixed dtypes, x with
// too few dims or a zero-sized normalised dim, weight/bias not (C), C not divisible by groups, groups < 1, eps < 0.
#pragma once
#include <cstdint>

#include "autograd/variable.h"

namespace t2m::ag {

Variable layer_norm(const Variable& x, const Variable& weight, const Variable& bias, double eps = 1e-5);
Variable rms_norm(const Variable& x, const Variable& weight, double eps = 1e-6);
Variable group_norm(const Variable& x, int64_t groups, const Variable& weight, const Variable& bias,
                    double eps = 1e-5);
Variable group_norm_relu(const Variable& x, int64_t groups, const Variable& weight, const Variable& bias,
                         double eps = 1e-5);

}  // namespace t2m::ag
