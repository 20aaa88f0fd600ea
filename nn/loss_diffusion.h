// loss_diffusion.h — the v-prediction diffusion objective (Salimans & Ho 2022) of the Text2BFM generator's
// diffusion variant (Table 5), next to Eq 14–15's flow matching (nn/loss_flow.h).
//
// Convention: x is data, eps ~ N(0, I) noise, t in [0, 1] the diffusion time (0 data, 1 noise) with a VP schedule
// (nn/diffusion_schedule.h) alpha(t), sigma(t).
//   diffusion_interpolate(x, eps, alpha, sigma) -> { x_t = alpha x + sigma eps, v = alpha eps − sigma x }
//     x, eps: one shape (B, ...), one float dtype; alpha, sigma: (B,) (or one element), broadcast over the other
//     dims. Gradients to x, eps, alpha and sigma.
//   diffusion_v_loss(v_pred, x, eps, alpha, sigma, opt) = mse_loss(v_pred, alpha eps − sigma x, opt)
//     opt as in flow_matching_loss (mean over elements; weights mask padded frames).
//   From a v prediction: x̂ = alpha x_t − sigma v, ε̂ = sigma x_t + alpha v (exact inverses when v is exact).
//   sample_diffusion_pair(x, gen, schedule) -> { t ~ U[0, 1) (B,), eps ~ N(0, I) (drawn after t, from gen),
//     alpha(t), sigma(t), x_t, v }: one training draw, no graph.
// Errors ("diffusion_interpolate: ..." etc.): x/eps shapes or dtypes differ, 0-d data, alpha/sigma not (B,) or one
// element, or of another dtype.
#pragma once
#include "autograd/variable.h"
#include "nn/diffusion_schedule.h"
#include "nn/loss_regression.h"
#include "tensor/rng.h"

namespace t2m::nn {

struct DiffusionPoint {
  ag::Variable x_t;  // alpha x + sigma eps
  ag::Variable v;    // alpha eps − sigma x, the v-prediction target
};

DiffusionPoint diffusion_interpolate(const ag::Variable& x, const ag::Variable& eps, const ag::Variable& alpha,
                                     const ag::Variable& sigma);

ag::Variable diffusion_v_loss(const ag::Variable& v_pred, const ag::Variable& x, const ag::Variable& eps,
                              const ag::Variable& alpha, const ag::Variable& sigma, const MseOptions& opt = {});

struct DiffusionSample {
  Tensor t, alpha, sigma;  // (B,)
  Tensor eps, x_t, v;      // x's shape
};
DiffusionSample sample_diffusion_pair(const Tensor& x, Generator& gen, NoiseSchedule schedule = NoiseSchedule::cosine);

}  // namespace t2m::nn
