// diffusion_schedule.cpp — closed forms of the cosine and linear VP schedules.
#include "nn/diffusion_schedule.h"

#include <cmath>
#include <numbers>

namespace t2m::nn {

namespace {

constexpr double kCosineS = 0.008;
constexpr double kBeta0 = 0.1, kBeta1 = 20.0;

void check_t(double t) {
  if (!(t >= 0.0 && t <= 1.0)) throw Error("diffusion schedule: t must be in [0, 1], got " + std::to_string(t));
}

Tensor map_times(const Tensor& t, double (*f)(NoiseSchedule, double), NoiseSchedule s) {
  if (!t.defined() || (t.dtype() != DType::f32 && t.dtype() != DType::f64))
    throw Error("diffusion schedule: times must be a float tensor");
  const Tensor c = t.to(DType::f64).contiguous();
  std::vector<double> v(c.data<double>(), c.data<double>() + c.numel());
  for (double& x : v) x = f(s, x);
  return Tensor::from_vector(v, t.shape()).to(t.dtype());
}

}  // namespace

NoiseSchedule noise_schedule_from_name(const std::string& name) {
  if (name == "cosine") return NoiseSchedule::cosine;
  if (name == "linear") return NoiseSchedule::linear;
  throw Error("diffusion schedule: unknown schedule '" + name + "' (cosine | linear)");
}

const char* noise_schedule_name(NoiseSchedule s) { return s == NoiseSchedule::cosine ? "cosine" : "linear"; }

double schedule_alpha(NoiseSchedule s, double t) {
  check_t(t);
  if (s == NoiseSchedule::cosine) {
    const double h = std::numbers::pi / 2;
    const double a = std::cos(h * (t + kCosineS) / (1 + kCosineS)) / std::cos(h * kCosineS / (1 + kCosineS));
    return t == 1.0 ? 0.0 : std::max(0.0, a);
  }
  return std::exp(-0.5 * (kBeta0 * t + 0.5 * (kBeta1 - kBeta0) * t * t));
}

double schedule_sigma(NoiseSchedule s, double t) {
  const double a = schedule_alpha(s, t);
  return std::sqrt(std::max(0.0, 1.0 - a * a));
}

Tensor schedule_alphas(NoiseSchedule s, const Tensor& t) { return map_times(t, schedule_alpha, s); }
Tensor schedule_sigmas(NoiseSchedule s, const Tensor& t) { return map_times(t, schedule_sigma, s); }

}  // namespace t2m::nn
