// diffusion_schedule.h — the Gaussian diffusion of the CASIM-MDM baseline (CASIM paper Eq 3; MDM, Tevet et al.
// 2023; DDPM, Ho et al. 2020): the cosine noise schedule (Nichol & Dhariwal 2021), the forward process q(x_t | x_0)
// and one reverse step from an x0-prediction (DDIM, Song et al. 2021, with eta: eta = 0 deterministic DDIM,
// eta = 1 the DDPM ancestral step on the strided sub-sequence of timesteps).
//
// Schedule (T steps, index t = 0 .. T-1; t = 0 is the least noisy): f(u) = cos^2(((u + s) / (1 + s)) pi / 2),
//   beta_t = min(1 - f((t + 1) / T) / f(t / T), max_beta), alpha_bar_t = prod_{i <= t} (1 - beta_i).
//   alpha_bar is strictly decreasing in t, alpha_bar_0 ~ 1 - 4e-5 (T = 1000), alpha_bar_{T-1} ~ 0 (< 1e-6).
// q_sample: x_t = sqrt(alpha_bar_t) x_0 + sqrt(1 - alpha_bar_t) eps, per sample b with its own t_b.
//   x0, eps (B, ...) float; t (B) int64 in [0, T) -> (B, ...) of x0's dtype.
// reverse_step (x0-parametrisation, CASIM Eq 3 mean mu(x_t, x0_hat)): from t to t_prev < t (t_prev = -1: the end,
//   alpha_bar = 1), with ab = alpha_bar_t, ap = alpha_bar_{t_prev}:
//   eps_hat = (x_t - sqrt(ab) x0_hat) / sqrt(1 - ab),
//   sigma   = eta sqrt((1 - ap) / (1 - ab)) sqrt(1 - ab / ap),
//   x_prev  = sqrt(ap) x0_hat + sqrt(1 - ap - sigma^2) eps_hat + sigma z,    z ~ N(0, I) (only drawn when sigma > 0)
//   For eta = 1 this is the DDPM posterior q(x_prev | x_t, x0_hat) of the strided chain (mean and variance).
//   All samples of a batch share (t, t_prev). x_t, x0_hat (B, ...) of one float dtype; noise drawn from gen.
// sampling_timesteps(T, K): K timesteps from T-1 down to 0, evenly spaced (rounded), strictly decreasing.
// Errors (t2m::Error "diffusion: ..."): T < 2, s <= 0, max_beta outside (0, 1], t out of range, t_prev >= t,
//   shape/dtype mismatches, K < 1 or K > T, eta < 0.
#pragma once
#include <cstdint>
#include <vector>

#include "tensor/rng.h"
#include "tensor/tensor.h"

namespace t2m::casim {

struct DiffusionSchedule {
  int64_t steps = 0;               // T
  std::vector<double> beta;        // (T)
  std::vector<double> alpha_bar;   // (T)
  double ab(int64_t t) const;      // alpha_bar_t, 1 for t = -1
};

// Nichol & Dhariwal 2021 Eq 17: the cosine schedule.
DiffusionSchedule cosine_schedule(int64_t T = 1000, double s = 0.008, double max_beta = 0.999);

// CASIM Eq 3 / DDPM Eq 4: q(x_t | x_0).
Tensor q_sample(const DiffusionSchedule& sch, const Tensor& x0, const Tensor& t, const Tensor& eps);

// DDIM Eq 12 (eta = 1: DDPM Eq 7 on the strided chain): one reverse step from an x0-prediction.
Tensor reverse_step(const DiffusionSchedule& sch, const Tensor& x_t, const Tensor& x0_hat, int64_t t, int64_t t_prev,
                    double eta, Generator& gen);

std::vector<int64_t> sampling_timesteps(int64_t T, int64_t K);

}  // namespace t2m::casim
