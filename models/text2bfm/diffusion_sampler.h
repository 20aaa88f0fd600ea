// diffusion_sampler.h — sampling compact motion programs with the DIFFUSION variant of the generator (Text2BFM
// Table 5: "Diffusion in pi_z-space", 50 steps): the same FlowGenerator network trained with the v-prediction
// objective (nn/loss_diffusion.h, gen_train.h objective "diffusion") and sampled with deterministic DDIM (eta = 0,
// Song et al. 2021).
//
// Time: the network's time input is r = 1 − t (r = 0 noise, r = 1 data, as for the flow), t the diffusion time of
// the VP schedule (nn/diffusion_schedule.h): x_t = alpha(t) x + sigma(t) eps.
// ddim_integrate(v, x1, steps, schedule): t_k = 1 − k / steps, k = 0..steps; for k = 0..steps-1:
//   v̂ = v(x, r = 1 − t_k);  x̂ = alpha_k x − sigma_k v̂;  ε̂ = sigma_k x + alpha_k v̂;
//   x ← alpha_{k+1} x̂ + sigma_{k+1} ε̂           (so the last step returns x̂ exactly: alpha(0) = 1, sigma(0) = 0).
//   v: any field (x (B, ...), r (B) of x's dtype) -> x's shape. With the exact v of a point mass at x* every step
//   returns x̂ = x* exactly; with the exact v of N(0, s^2 I) data it follows the probability-flow ODE (x -> s x).
// sample_programs_diffusion(gen, tokens, tok_mask, Tm, rng, opt): x(t = 1) ~ N(0, I) (B, Tm, latent) from rng,
//   then DDIM with the classifier-free guided v (flow_sampler.h guided_field: v_u + w (v_c − v_u)); no graph.
// Errors (t2m::Error "diffusion_sampler: ..."): steps < 1, a field returning the wrong shape or dtype, Tm < 1;
//   guided_field's errors (non-finite w, token shapes) pass through.
#pragma once
#include <cstdint>

#include "models/text2bfm/flow_sampler.h"
#include "nn/diffusion_schedule.h"

namespace t2m::text2bfm {

struct DiffusionSamplerOptions {
  int64_t steps = 50;     // DDIM steps (the paper's diffusion variant: 50)
  double guidance = 1.5;  // classifier-free guidance weight w
  nn::NoiseSchedule schedule = nn::NoiseSchedule::cosine;
};

// DDIM (eta = 0) from t = 1 to t = 0 with a v-prediction field.
Tensor ddim_integrate(const VelocityField& v, const Tensor& x1, int64_t steps, nn::NoiseSchedule schedule);

Tensor sample_programs_diffusion(const FlowGenerator& gen, const Tensor& tokens, const Tensor& tok_mask, int64_t Tm,
                                 Generator& rng, const DiffusionSamplerOptions& opt = {});

}  // namespace t2m::text2bfm
