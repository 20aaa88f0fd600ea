// diffusion_schedule.h — noise schedules of a variance-preserving diffusion in continuous time (the diffusion
// variant of the Text2BFM generator, Table 5): x_t = alpha(t) x + sigma(t) eps, alpha^2 + sigma^2 = 1,
// t in [0, 1], t = 0 data, t = 1 (almost) pure noise.
//
//   cosine (Nichol & Dhariwal 2021, the default): alpha(t) = cos(pi/2 (t + s)/(1 + s)) / cos(pi/2 s/(1 + s)),
//          s = 0.008; alpha(0) = 1, alpha(1) = 0 exactly.
//   linear (DDPM's linear beta in continuous time, Song et al. 2021 VP-SDE): alpha(t)^2 =
//          exp(-(beta0 t + (beta1 - beta0) t^2 / 2)), beta0 = 0.1, beta1 = 20 (= 1000 x DDPM's 1e-4 .. 0.02);
//          alpha(1)^2 = exp(-10.05) = 4.3e-5.
// sigma(t) = sqrt(1 - alpha(t)^2) for both (clamped at 0). alphas(t) / sigmas(t): elementwise on a tensor of
// times (any shape, float dtype) -> the same shape and dtype.
// Errors (t2m::Error "diffusion schedule: ..."): t outside [0, 1] or non-finite, an unknown name, a non-float
// tensor.
#pragma once
#include <string>

#include "tensor/tensor.h"

namespace t2m::nn {

enum class NoiseSchedule { cosine, linear };

NoiseSchedule noise_schedule_from_name(const std::string& name);  // "cosine" | "linear"
const char* noise_schedule_name(NoiseSchedule s);

double schedule_alpha(NoiseSchedule s, double t);
double schedule_sigma(NoiseSchedule s, double t);
Tensor schedule_alphas(NoiseSchedule s, const Tensor& t);
Tensor schedule_sigmas(NoiseSchedule s, const Tensor& t);

}  // namespace t2m::nn
