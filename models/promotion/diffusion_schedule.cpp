// diffusion_schedule.cpp — closed-form DDPM quantities in double, applied per element.
#include "models/promotion/diffusion_schedule.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace t2m::promotion {

namespace {

const double kPi = 3.14159265358979323846;

void check_same(const Tensor& a, const Tensor& b, const char* an, const char* bn) {
  if (!a.defined() || !b.defined() || a.shape() != b.shape() || a.dtype() != b.dtype() || a.dim() < 1 ||
      (a.dtype() != DType::f32 && a.dtype() != DType::f64))
    throw Error(std::string("diffusion_schedule: ") + an + " and " + bn + " must be float tensors of one shape "
                "(B, ...) and dtype, got " + (a.defined() ? shape_str(a.shape()) : "undefined") + " and " +
                (b.defined() ? shape_str(b.shape()) : "undefined"));
}

// out = ca[b] * a + cb[b] * b (+ cz[b] * z when z is given), row b of the batch.
Tensor combine(const Tensor& a, const Tensor& b, const Tensor& z, const std::vector<double>& ca,
               const std::vector<double>& cb, const std::vector<double>& cz) {
  const Tensor ac = a.contiguous(), bc = b.contiguous(), zc = z.defined() ? z.contiguous() : Tensor();
  Tensor out = Tensor::empty(a.shape(), a.dtype());
  const int64_t B = a.size(0), n = a.numel() / std::max<int64_t>(B, 1);
  auto run = [&](auto tag) {
    using T = decltype(tag);
    const T* pa = ac.data<T>();
    const T* pb = bc.data<T>();
    const T* pz = zc.defined() ? zc.data<T>() : nullptr;
    T* po = out.data<T>();
    for (int64_t r = 0; r < B; ++r)
      for (int64_t i = r * n; i < (r + 1) * n; ++i) {
        double v = ca[r] * (double)pa[i] + cb[r] * (double)pb[i];
        if (pz) v += cz[r] * (double)pz[i];
        po[i] = (T)v;
      }
  };
  if (a.dtype() == DType::f32) run(float{});
  else run(double{});
  return out;
}

}  // namespace

DiffusionSchedule::DiffusionSchedule(std::vector<double> betas) : beta_(std::move(betas)) {
  double p = 1;
  for (double b : beta_) {
    if (!(b > 0 && b < 1)) throw Error("diffusion_schedule: beta " + std::to_string(b) + " outside (0, 1)");
    p *= 1 - b;
    abar_.push_back(p);
  }
}

// Ho et al. 2020, Sec 4: betas linear in t.
DiffusionSchedule DiffusionSchedule::linear(int steps, double beta_start, double beta_end) {
  if (steps < 1) throw Error("diffusion_schedule: steps " + std::to_string(steps) + " < 1");
  std::vector<double> b(steps);
  for (int t = 0; t < steps; ++t)
    b[t] = steps == 1 ? beta_start : beta_start + (beta_end - beta_start) * t / (steps - 1);
  return DiffusionSchedule(std::move(b));
}

// Nichol & Dhariwal 2021, Eq 17: alpha_bar from a squared cosine, betas clipped at max_beta.
DiffusionSchedule DiffusionSchedule::cosine(int steps, double s, double max_beta) {
  if (steps < 1) throw Error("diffusion_schedule: steps " + std::to_string(steps) + " < 1");
  if (!(s >= 0) || !(max_beta > 0 && max_beta < 1))
    throw Error("diffusion_schedule: cosine needs s >= 0 and max_beta in (0, 1), got s = " + std::to_string(s) +
                ", max_beta = " + std::to_string(max_beta));
  auto f = [&](double u) {
    const double c = std::cos((u / steps + s) / (1 + s) * kPi / 2);
    return c * c;
  };
  std::vector<double> b(steps);
  for (int t = 0; t < steps; ++t) b[t] = std::min(1 - f(t + 1) / f(t), max_beta);
  return DiffusionSchedule(std::move(b));
}

void DiffusionSchedule::check_step(int t) const {
  if (t < 0 || t >= steps())
    throw Error("diffusion_schedule: step " + std::to_string(t) + " outside [0, " + std::to_string(steps()) + ")");
}

double DiffusionSchedule::beta(int t) const {
  check_step(t);
  return beta_[t];
}

double DiffusionSchedule::alpha_bar(int t) const {
  if (t == -1) return 1.0;
  check_step(t);
  return abar_[t];
}

// DDPM Eq 7: beta~_t = beta_t (1 - alpha_bar_{t-1}) / (1 - alpha_bar_t).
double DiffusionSchedule::posterior_variance(int t) const {
  check_step(t);
  return beta_[t] * (1 - alpha_bar(t - 1)) / (1 - abar_[t]);
}

// DDPM Eq 4: q(x_t | x_0) = N(sqrt(alpha_bar_t) x_0, (1 - alpha_bar_t) I).
Tensor DiffusionSchedule::q_sample(const Tensor& x0, const Tensor& t, const Tensor& eps) const {
  check_same(x0, eps, "x0", "eps");
  if (!t.defined() || t.dtype() != DType::i64 || t.dim() != 1 || t.size(0) != x0.size(0))
    throw Error("diffusion_schedule: q_sample needs int64 steps (" + std::to_string(x0.size(0)) + "), got " +
                (t.defined() ? shape_str(t.shape()) + " " + dtype_name(t.dtype()) : std::string("undefined")));
  const auto tv = t.contiguous().to_vector<int64_t>();
  std::vector<double> ca(tv.size()), ce(tv.size());
  for (size_t b = 0; b < tv.size(); ++b) {
    check_step((int)tv[b]);
    ca[b] = std::sqrt(abar_[tv[b]]);
    ce[b] = std::sqrt(1 - abar_[tv[b]]);
  }
  return combine(x0, eps, Tensor(), ca, ce, {});
}

// DDPM Eq 6–7: x_{t-1} ~ N(c0 x0_hat + c1 x_t, beta~_t I).
Tensor DiffusionSchedule::ddpm_step(const Tensor& x_t, const Tensor& x0_hat, int t, const Tensor& z) const {
  check_same(x_t, x0_hat, "x_t", "x0_hat");
  check_step(t);
  const double ab = abar_[t], ab_prev = alpha_bar(t - 1), b = beta_[t];
  const double c0 = b * std::sqrt(ab_prev) / (1 - ab), c1 = (1 - ab_prev) * std::sqrt(1 - b) / (1 - ab);
  const int64_t B = x_t.size(0);
  const bool noise = t > 0;
  if (noise) check_same(x_t, z, "x_t", "z");
  return combine(x0_hat, x_t, noise ? z : Tensor(), std::vector<double>(B, c0), std::vector<double>(B, c1),
                 std::vector<double>(B, noise ? std::sqrt(posterior_variance(t)) : 0.0));
}

// DDIM Eq 12 with sigma of Eq 16, written as one linear combination of x0_hat, x_t and z.
Tensor DiffusionSchedule::ddim_step(const Tensor& x_t, const Tensor& x0_hat, int t, int p, double eta,
                                    const Tensor& z) const {
  check_same(x_t, x0_hat, "x_t", "x0_hat");
  check_step(t);
  if (p < -1 || p >= t)
    throw Error("diffusion_schedule: ddim_step needs -1 <= p < t, got t = " + std::to_string(t) + ", p = " +
                std::to_string(p));
  if (!(eta >= 0 && eta <= 1)) throw Error("diffusion_schedule: eta " + std::to_string(eta) + " outside [0, 1]");
  const double ab = abar_[t], ab_p = alpha_bar(p);
  const double sigma = eta * std::sqrt(std::max(0.0, (1 - ab_p) / (1 - ab) * (1 - ab / ab_p)));
  const double dir = std::sqrt(std::max(0.0, 1 - ab_p - sigma * sigma)) / std::sqrt(1 - ab);
  const double c0 = std::sqrt(ab_p) - dir * std::sqrt(ab), c1 = dir;
  const int64_t B = x_t.size(0);
  const bool noise = sigma > 0;
  if (noise) check_same(x_t, z, "x_t", "z");
  return combine(x0_hat, x_t, noise ? z : Tensor(), std::vector<double>(B, c0), std::vector<double>(B, c1),
                 std::vector<double>(B, noise ? sigma : 0.0));
}

Tensor DiffusionSchedule::sample_steps(int64_t batch, Generator& gen) const {
  return randint({batch}, gen, 0, steps());
}

Tensor ddpm_sample(const DiffusionSchedule& s, const Shape& shape,
                   const std::function<Tensor(const Tensor& x_t, int t)>& predict_x0, Generator& gen) {
  Tensor x = rand_normal(shape, gen);
  for (int t = s.steps() - 1; t >= 0; --t) {
    const Tensor x0 = predict_x0(x, t);
    x = s.ddpm_step(x, x0, t, t > 0 ? rand_normal(shape, gen) : Tensor());
  }
  return x;
}

std::vector<int> ddim_timesteps(int T, int n) {
  if (n < 1 || n > T)
    throw Error("diffusion_schedule: DDIM steps " + std::to_string(n) + " outside [1, " + std::to_string(T) + "]");
  std::vector<int> tau(n);
  for (int i = 0; i < n; ++i) tau[n - 1 - i] = (int)(((int64_t)(i + 1) * T) / n) - 1;
  return tau;
}

Tensor ddim_sample(const DiffusionSchedule& s, const Shape& shape,
                   const std::function<Tensor(const Tensor& x_t, int t)>& predict_x0, Generator& gen, int n,
                   double eta) {
  const std::vector<int> tau = ddim_timesteps(s.steps(), n);
  if (!(eta >= 0 && eta <= 1)) throw Error("diffusion_schedule: eta " + std::to_string(eta) + " outside [0, 1]");
  Tensor x = rand_normal(shape, gen);
  for (size_t i = 0; i < tau.size(); ++i) {
    const int t = tau[i], p = i + 1 < tau.size() ? tau[i + 1] : -1;
    const Tensor x0 = predict_x0(x, t);
    x = s.ddim_step(x, x0, t, p, eta, p >= 0 && eta > 0 ? rand_normal(shape, gen) : Tensor());
  }
  return x;
}

}  // namespace t2m::promotion
