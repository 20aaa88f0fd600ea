// diffusion_sampler.h — sampling motions from the CASIM-MDM denoiser: the reverse process of
// diffusion_schedule.h driven by x0-predictions, with classifier-free guidance (Ho & Salimans 2022).
//
// diffusion_sample(sch, x0_fn, x_T, opt, gen): K = opt.steps timesteps t_0 > ... > t_{K-1} = 0 from
//   sampling_timesteps(T, K); x <- reverse_step(x, x0_fn(x, t_k), t_k, t_{k+1}, eta) with t_K = -1, so the last step
//   returns the final x0-prediction. eta = 0: DDIM (deterministic given x_T), eta = 1: DDPM ancestral steps on the
//   strided chain (K = T: the full DDPM sampler). x0_fn(x (B, ...), t) -> (B, ...) of x's shape and dtype.
// guided_x0(c, u, w) = u + w (c - u): w = 1 is the conditional prediction exactly, w = 0 the unconditional one.
// sample_motions(model, sch, text, frame_mask, T, opt, gen): x_T ~ N(0, I) (B, T, F) from gen, then
//   diffusion_sample with the guided prediction; the conditional and null passes of a step run as one batch of
//   2B (w = 1: conditional pass only). No autograd graph (NoGradGuard). Returns normalised features (B, T, F).
// Defaults (CPU budget; MDM uses 1000 DDPM steps, CASIM reports 50): DDIM 50 steps, eta 0, w = 2.5 (MDM's scale).
// Errors (t2m::Error "diffusion sampler: ..."): an x0_fn returning the wrong shape/dtype, T < 1, frame_mask not
//   (B, T), non-finite w; schedule and model errors pass through.
#pragma once
#include <cstdint>
#include <functional>

#include "models/casim/diffusion_denoiser.h"
#include "models/casim/diffusion_schedule.h"
#include "tensor/rng.h"
#include "tensor/tensor.h"

namespace t2m::casim {

using X0Predictor = std::function<Tensor(const Tensor& x_t, int64_t t)>;

struct SamplerOptions {
  int64_t steps = 50;     // K reverse steps
  double eta = 0.0;       // 0 = DDIM, 1 = DDPM
  double guidance = 2.5;  // classifier-free guidance weight w
};

Tensor diffusion_sample(const DiffusionSchedule& sch, const X0Predictor& x0_fn, const Tensor& x_T,
                        const SamplerOptions& opt, Generator& gen);

// Ho & Salimans 2022 Eq 6 (on x0 instead of eps: the same affine combination).
Tensor guided_x0(const Tensor& cond, const Tensor& uncond, double w);

Tensor sample_motions(const CasimDenoiser& model, const DiffusionSchedule& sch, const DiffusionText& text,
                      const Tensor& frame_mask, int64_t T, const SamplerOptions& opt, Generator& gen);

}  // namespace t2m::casim
