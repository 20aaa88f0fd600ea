// loss_gaussian.h — KL divergences of diagonal Gaussians: the VAE prior term (Eq 6) and the policy KL of Eq 5 /
// the Action KL metric of Eq 21.
//
// kl_standard_normal(mu, logvar, reduction, weights) — Eq 6, KL(N(mu, diag(exp(logvar))) || N(0, I)):
//   per element  k_e = 0.5 * (mu_e^2 + exp(logvar_e) - 1 - logvar_e)   (>= 0, = 0 iff mu = 0 and logvar = 0)
//   mu, logvar: one shape (B, ...) (e.g. the (B, C, T_m) posterior of the VBB encoder), one float dtype.
//   reduction (the paper leaves it open):
//     mean_elements  sum_e w_e k_e / sum_e w_e — the anchor's  -0.5 * mean(1 + logvar - mu^2 - exp(logvar)),
//                    the scale that β = 1e-4 of Eq 13 was tuned with in the anchor (default);
//     batch_mean     sum_e w_e k_e / B — the exact KL of each sample's whole program m_{1:T_m}, averaged over
//                    the batch (dim 0);
//     sum            sum_e w_e k_e.
//   weights: undefined or broadcastable to mu (0/1 mask of padded latent frames, e.g. (B, 1, T_m)).
//   Errors ("kl_standard_normal: ..."): shapes/dtypes differ (names both), batch_mean of a 0-d input, bad weights.
//
// kl_diag_gaussians(mu1, scale1, mu2, scale2, param) — KL(p || q) with p = N(mu1, diag σ1²), q = N(mu2, diag σ2²),
//   summed over the last dim (independent coordinates, e.g. action dims):
//     KL = sum_a [ log σ2 - log σ1 + (σ1² + (mu1 - mu2)²) / (2 σ2²) - 1/2 ]
//   evaluated as (l2 - l1) + 0.5 (exp(2 (l1 - l2)) + (mu1 - mu2)² exp(-2 l2)) - 0.5 with l = log σ (no division
//   by a tiny σ, no log of an underflowed σ). param says whether scale1/scale2 hold log σ (log_std, the default,
//   Meta Motivo's actor) or log σ² (log_var). mu1, mu2: one shape (..., A), at least 1-D; scale1/scale2
//   broadcastable to it (e.g. a fixed (A,) or 0-d log std). Result: shape (...) (mu's shape without the last
//   dim); gradients to all four inputs. Argument order is the paper's: Eq 5 and Eq 21 use
//   KL(π(·|s, ẑ) || π(·|s, z)), so (mu1, scale1) come from the reconstructed latent ẑ and (mu2, scale2) from z.
//   The Eq 5 term λπ/T_z sum_t KL_t is  λπ * weighted_mean(kl_diag_gaussians(...), frame_mask).
//   Errors ("kl_diag_gaussians: ..."): mu shapes differ, 0-d mu, a scale not broadcastable to mu, dtype mismatch.
//
// action_kl(...) — Eq 21 as a metric on plain tensors (no graph): the (weighted) mean over all frames of
//   kl_diag_gaussians; frame_weights undefined or broadcastable to mu's shape without the last dim.
#pragma once
#include "autograd/variable.h"

namespace t2m::nn {

enum class KlReduction { mean_elements, batch_mean, sum };
enum class GaussianScale { log_std, log_var };

ag::Variable kl_standard_normal(const ag::Variable& mu, const ag::Variable& logvar,
                                KlReduction reduction = KlReduction::mean_elements, const Tensor& weights = Tensor());

ag::Variable kl_diag_gaussians(const ag::Variable& mu1, const ag::Variable& scale1, const ag::Variable& mu2,
                               const ag::Variable& scale2, GaussianScale param = GaussianScale::log_std);

double action_kl(const Tensor& mu_hat, const Tensor& scale_hat, const Tensor& mu, const Tensor& scale,
                 GaussianScale param = GaussianScale::log_std, const Tensor& frame_weights = Tensor());

}  // namespace t2m::nn
