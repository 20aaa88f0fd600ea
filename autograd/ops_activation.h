// ops_activation.h — differentiable activations not in ops_unary.h, and dropout. float32 and float64; out has
// x's shape and dtype (a fresh contiguous tensor; inputs of any strides accepted).
//
// gelu_tanh(x) = 0.5 x (1 + tanh(sqrt(2/pi) (x + 0.044715 x^3)))   (Hendrycks & Gimpel 2016, tanh form; the
//   fused kernel of tensor/fused/gelu_tanh.h, float absolute error ~1e-7).
// silu(x) = x * sigmoid(x)   (a.k.a. swish);  silu'(x) = s (1 + x (1 - s)), s = sigmoid(x).
// dropout(x, p, gen, training): inverted dropout. When training and p > 0, every element is kept with
//   probability 1 - p and scaled by 1 / (1 - p), else zeroed (p = 1 zeroes everything). The keep mask is
//   rand_bernoulli(x.shape(), gen, 1 - p) (Philox: element i depends only on the generator state and i, so a
//   seed gives the same mask for any thread count); the generator advances exactly as that draw does.
//   When not training or p == 0, x is returned as is (same Variable, no copy, generator untouched).
//   The gradient is g * mask / (1 - p).
// residual_dropout(x, h, p, gen, training) = add(x, dropout(h, p, gen, training)) in one pass (a residual branch
//   with dropout: no separate dropout output is written and re-read): the same bits, the same mask and the same
//   generator advance. Falls back to the two ops when x and h differ in shape or dtype (broadcasting add).
// Errors (t2m::Error naming the op and the shape): non-float dtype; dropout with p outside [0, 1].
#pragma once
#include "autograd/variable.h"
#include "tensor/rng.h"

namespace t2m::ag {

Variable gelu_tanh(const Variable& x);
Variable silu(const Variable& x);
Variable dropout(const Variable& x, double p, Generator& gen, bool training);
Variable residual_dropout(const Variable& x, const Variable& h, double p, Generator& gen, bool training);

}  // namespace t2m::ag
