// diffusion_schedule.h — DDPM noise schedules and the two operations every DDPM of the PRO-Motion baseline needs:
// the forward process q(x_t | x_0) and the ancestral step p(x_{t-1} | x_t) from a predicted x_0 (Ho et al. 2020).
// Used by the go-diffuser (cosine, 100 steps: PRO-Motion App. D) and available to the posture diffuser (linear
// 0.00085–0.012).
//
// Steps are 0-based, t = 0..T-1 (t = 0 is the least noisy); alpha_bar[t] = prod_{s<=t} (1 - beta[s]).
//   linear(T, b0, b1):  beta[t] = b0 + (b1 - b0) t / (T - 1)            (Ho et al.; T = 1: beta = b0)
//   cosine(T, s):       f(u) = cos^2(((u / T) + s) / (1 + s) * pi / 2),
//                       beta[t] = min(1 - f(t + 1) / f(t), max_beta)      (Nichol & Dhariwal 2021, Eq 17; s = 0.008,
//                       max_beta = 0.999), so alpha_bar[t] = f(t + 1) / f(0) while no clipping happens.
// q_sample:   x_t = sqrt(alpha_bar[t]) x_0 + sqrt(1 - alpha_bar[t]) eps                      (DDPM Eq 4)
// posterior:  mean = c0[t] x_0 + c1[t] x_t,  c0 = beta[t] sqrt(alpha_bar[t-1]) / (1 - alpha_bar[t]),
//             c1 = (1 - alpha_bar[t-1]) sqrt(1 - beta[t]) / (1 - alpha_bar[t]),
//             var[t] = beta[t] (1 - alpha_bar[t-1]) / (1 - alpha_bar[t])  (DDPM Eq 6–7; alpha_bar[-1] = 1, so
//             var[0] = 0 and the last step returns x_0 exactly)
//   ddpm_step: x_{t-1} = mean + sqrt(var[t]) z, z ~ N(0, I) given by the caller (ignored at t = 0).
// DDIM (Song et al. 2021, Eq 12) from step t to an earlier step p (p = -1: the clean sample), x_0 estimate x0:
//   eps = (x_t - sqrt(abar[t]) x0) / sqrt(1 - abar[t]),
//   sigma = eta sqrt((1 - abar[p]) / (1 - abar[t]) (1 - abar[t] / abar[p])),               (DDIM Eq 16)
//   x_p = sqrt(abar[p]) x0 + sqrt(1 - abar[p] - sigma^2) eps + sigma z.
//   eta = 0: deterministic; eta = 1 with p = t - 1: exactly the DDPM ancestral step (sigma^2 = var[t]).
// Tensors: x_0, x_t, eps, z of one shape (B, ...) and one float dtype; t an int64 (B) tensor (q_sample: one step
// per batch row) or one int (ddpm_step: the same step for the whole batch). Computed in double per element.
// Errors (t2m::Error, "diffusion_schedule: ..."): T < 1, betas outside (0, 1), s < 0; shapes/dtypes that differ;
// t outside [0, T).
#pragma once
#include <cstdint>
#include <functional>
#include <vector>

#include "tensor/rng.h"
#include "tensor/tensor.h"

namespace t2m::promotion {

class DiffusionSchedule {
 public:
  static DiffusionSchedule linear(int steps, double beta_start, double beta_end);
  static DiffusionSchedule cosine(int steps, double s = 0.008, double max_beta = 0.999);

  int steps() const { return (int)beta_.size(); }
  double beta(int t) const;
  double alpha_bar(int t) const;  // t = -1 gives 1
  double posterior_variance(int t) const;

  // DDPM Eq 4: x_t for each batch row b at step t[b].
  Tensor q_sample(const Tensor& x0, const Tensor& t, const Tensor& eps) const;
  // DDPM Eq 6–7: one ancestral step from x_t at step t with the model's x_0 estimate.
  Tensor ddpm_step(const Tensor& x_t, const Tensor& x0_hat, int t, const Tensor& z) const;
  // DDIM Eq 12: the step t -> p (-1 <= p < t) with stochasticity eta in [0, 1]; z ignored when sigma = 0.
  Tensor ddim_step(const Tensor& x_t, const Tensor& x0_hat, int t, int p, double eta, const Tensor& z) const;
  // Uniform training steps in [0, T): int64 (B).
  Tensor sample_steps(int64_t batch, Generator& gen) const;

 private:
  explicit DiffusionSchedule(std::vector<double> betas);
  void check_step(int t) const;
  std::vector<double> beta_, abar_;
};

// The DDPM ancestral sampler: x_{T-1} ~ N(0, I) of `shape`, then for t = T-1 .. 0
// x_{t-1} = ddpm_step(x_t, predict_x0(x_t, t), t, z). All noise from `gen` (float32). Returns x_{-1}, the sample.
Tensor ddpm_sample(const DiffusionSchedule& s, const Shape& shape,
                   const std::function<Tensor(const Tensor& x_t, int t)>& predict_x0, Generator& gen);

// The strided DDIM sampler: n of the T steps, tau_i = floor((i + 1) T / n) - 1 (i = n-1 .. 0, so T-1 is always
// the first), x_{T-1} ~ N(0, I), then ddim_step(tau_i -> tau_{i-1}) down to -1. Noise is drawn only when sigma > 0,
// in the order ddpm_sample draws it, so ddim_sample(n = T, eta = 1) reproduces ddpm_sample for the same generator.
// Errors: n outside [1, T], eta outside [0, 1].
Tensor ddim_sample(const DiffusionSchedule& s, const Shape& shape,
                   const std::function<Tensor(const Tensor& x_t, int t)>& predict_x0, Generator& gen, int n,
                   double eta);
// The DDIM subsequence of n steps in descending order (T-1 first).
std::vector<int> ddim_timesteps(int T, int n);

}  // namespace t2m::promotion
