// loss_reduce.h — the reductions and mask checks shared by the losses in nn/loss_*.h.
//
// weighted_mean(values, weights) = sum(w * v) / sum(w expanded to v's shape)
//   values: any shape V, float32/float64. weights: undefined (plain mean over every element) or a tensor of any
//   dtype (converted to v's dtype) whose shape broadcasts TO V under numpy rules, e.g. (B, T, 1) per-frame
//   weights for (B, T, D) values, or a 0/1 padding mask. Weights must be finite and >= 0. Entries with weight 0
//   contribute neither value nor gradient (their values must be finite: 0 * inf is NaN). When every weight is 0
//   the result is 0 with zero gradient (an all-padding batch adds nothing), not NaN.
//   No gradient flows to the weights (they are data: masks, per-frame importance).
//   Errors (t2m::Error, message starts with `op`): weights not broadcastable to V (names both shapes), negative
//   or non-finite weights (names the value), undefined values.
//
// valid_mask(mask, shape, dtype, op, what): checks a key-padding mask (any dtype; nonzero = valid, 0 = padding)
//   of exactly `shape` and returns it as a 0/1 tensor of `dtype`. Error names op, what and both shapes.
#pragma once
#include "autograd/variable.h"

namespace t2m::nn {

ag::Variable weighted_mean(const ag::Variable& values, const Tensor& weights = Tensor(),
                           const char* op = "weighted_mean");
// sum(w * v) (sum(v) without weights), with the same weight checks as weighted_mean.
ag::Variable weighted_sum(const ag::Variable& values, const Tensor& weights = Tensor(),
                          const char* op = "weighted_sum");

// True when a tensor of shape `from` broadcasts to exactly `to` (numpy rules, right-aligned); never throws.
bool broadcasts_to(const Shape& from, const Shape& to);

Tensor valid_mask(const Tensor& mask, const Shape& shape, DType dtype, const char* op, const char* what);

}  // namespace t2m::nn
