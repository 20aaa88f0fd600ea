// loss_regression.h — mean squared error with optional per-frame weights / padding masks.
//
// mse_loss(pred, target, opt): pred and target of one shape V (..., D), one float dtype; gradients to both.
//   opt.sum_last_dim == false (default):  sum_e w_e (pred_e - target_e)^2 / sum_e w_e   over all elements e
//     = torch.nn.functional.mse_loss (what the anchor's VAE and FM steps use) when no weights are given.
//   opt.sum_last_dim == true:  sum_f w_f ||pred_f - target_f||_2^2 / sum_f w_f   over frames f (all but the last
//     dim) = the first term of Eq 5, (1/T_z) sum_t ||z_t - ẑ_t||^2, and the squared norm of Eq 15.
//   opt.weights: undefined, or broadcastable to V (numpy rules) as in nn/loss_reduce.h (e.g. a (B, T, 1)
//     0/1 frame mask for (B, T, D)); with sum_last_dim it must have size 1 in its last dim (per-frame weights)
//     or be 0-d. Padded entries (weight 0) do not change the loss and get zero gradient. All weights 0 -> 0.
// Errors (t2m::Error, "mse_loss: ..."): pred/target shapes or dtypes differ (names both), 0-d inputs with
//   sum_last_dim, weights not broadcastable / negative / varying along the summed last dim.
#pragma once
#include "autograd/variable.h"

namespace t2m::nn {

struct MseOptions {
  Tensor weights;             // optional frame/element weights or 0/1 mask, broadcastable to pred
  bool sum_last_dim = false;  // true: squared L2 norm over the last dim, weighted mean over the other dims
};

ag::Variable mse_loss(const ag::Variable& pred, const ag::Variable& target, const MseOptions& opt = {});

}  // namespace t2m::nn
