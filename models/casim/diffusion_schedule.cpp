// diffusion_schedule.cpp — cosine schedule, forward noising and the DDIM/DDPM reverse step (double-precision
// coefficients, elementwise loops in the tensors' dtype).
#include "models/casim/diffusion_schedule.h"

#include <cmath>
#include <numbers>
#include <string>

namespace t2m::casim {

namespace {

template <typename T>
void axpby_rows(const Tensor& a, const Tensor& b, const std::vector<double>& ca, const std::vector<double>& cb,
                Tensor& out) {
  const int64_t B = a.size(0), n = a.numel() / std::max<int64_t>(B, 1);
  const T* pa = a.data<T>();
  const T* pb = b.data<T>();
  T* po = out.data<T>();
  for (int64_t i = 0; i < B; ++i)
    for (int64_t k = 0; k < n; ++k) po[i * n + k] = T(ca[(size_t)i] * pa[i * n + k] + cb[(size_t)i] * pb[i * n + k]);
}

void check_pair(const Tensor& a, const Tensor& b, const char* who) {
  if (!a.defined() || !b.defined() || a.shape() != b.shape() || a.dtype() != b.dtype() || a.dim() < 1 ||
      (a.dtype() != DType::f32 && a.dtype() != DType::f64))
    throw Error(std::string("diffusion: ") + who + " needs two float tensors of one shape (B, ...) and dtype");
}

// out = ca[b] a + cb[b] b per sample b.
Tensor combine(const Tensor& a, const Tensor& b, const std::vector<double>& ca, const std::vector<double>& cb) {
  const Tensor ac = a.contiguous(), bc = b.contiguous();
  Tensor out = Tensor::empty(a.shape(), a.dtype());
  if (a.dtype() == DType::f64)
    axpby_rows<double>(ac, bc, ca, cb, out);
  else
    axpby_rows<float>(ac, bc, ca, cb, out);
  return out;
}

}  // namespace

double DiffusionSchedule::ab(int64_t t) const {
  if (t == -1) return 1.0;
  if (t < 0 || t >= steps)
    throw Error("diffusion: timestep " + std::to_string(t) + " outside [-1, " + std::to_string(steps) + ")");
  return alpha_bar[(size_t)t];
}

// Nichol & Dhariwal 2021 Eq 17: alpha_bar from f(u) = cos^2(((u + s) / (1 + s)) pi / 2), betas clipped.
DiffusionSchedule cosine_schedule(int64_t T, double s, double max_beta) {
  if (T < 2 || !(s > 0) || !(max_beta > 0) || max_beta > 1)
    throw Error("diffusion: cosine schedule needs T >= 2, s > 0, max_beta in (0, 1] (got T " + std::to_string(T) +
                ", s " + std::to_string(s) + ", max_beta " + std::to_string(max_beta) + ")");
  auto f = [&](double u) {
    const double c = std::cos((u + s) / (1 + s) * std::numbers::pi / 2);
    return c * c;
  };
  DiffusionSchedule d;
  d.steps = T;
  double prod = 1;
  for (int64_t t = 0; t < T; ++t) {
    const double b = std::min(1 - f(double(t + 1) / T) / f(double(t) / T), max_beta);
    prod *= 1 - b;
    d.beta.push_back(b);
    d.alpha_bar.push_back(prod);
  }
  return d;
}

// CASIM Eq 3 / DDPM Eq 4: x_t = sqrt(ab_t) x0 + sqrt(1 - ab_t) eps.
Tensor q_sample(const DiffusionSchedule& sch, const Tensor& x0, const Tensor& t, const Tensor& eps) {
  check_pair(x0, eps, "q_sample");
  if (!t.defined() || t.dtype() != DType::i64 || t.dim() != 1 || t.size(0) != x0.size(0))
    throw Error("diffusion: q_sample needs t (B) int64 for x0 with B = " + std::to_string(x0.size(0)));
  const Tensor tc = t.contiguous();
  std::vector<double> ca, cb;
  for (int64_t i = 0; i < t.size(0); ++i) {
    const int64_t ti = tc.data<int64_t>()[i];
    if (ti < 0 || ti >= sch.steps)
      throw Error("diffusion: q_sample timestep " + std::to_string(ti) + " outside [0, " +
                  std::to_string(sch.steps) + ")");
    ca.push_back(std::sqrt(sch.alpha_bar[(size_t)ti]));
    cb.push_back(std::sqrt(1 - sch.alpha_bar[(size_t)ti]));
  }
  return combine(x0, eps, ca, cb);
}

// DDIM Eq 12 with eta (eta = 1: the DDPM posterior of the strided chain).
Tensor reverse_step(const DiffusionSchedule& sch, const Tensor& x_t, const Tensor& x0_hat, int64_t t, int64_t t_prev,
                    double eta, Generator& gen) {
  check_pair(x_t, x0_hat, "reverse_step");
  if (t < 0 || t >= sch.steps || t_prev < -1 || t_prev >= t)
    throw Error("diffusion: reverse_step needs 0 <= t < T and -1 <= t_prev < t (got t " + std::to_string(t) +
                ", t_prev " + std::to_string(t_prev) + ", T " + std::to_string(sch.steps) + ")");
  if (!(eta >= 0)) throw Error("diffusion: reverse_step eta must be >= 0");
  const double ab = sch.ab(t), ap = sch.ab(t_prev);
  const double sigma = eta * std::sqrt((1 - ap) / (1 - ab)) * std::sqrt(1 - ab / ap);
  const double ce = std::sqrt(std::max(1 - ap - sigma * sigma, 0.0));
  // x_prev = sqrt(ap) x0 + ce (x_t - sqrt(ab) x0) / sqrt(1 - ab) = [sqrt(ap) - ce sqrt(ab / (1 - ab))] x0 + ce / sqrt(1 - ab) x_t
  const int64_t B = x_t.size(0);
  const std::vector<double> c0((size_t)B, std::sqrt(ap) - ce * std::sqrt(ab / (1 - ab)));
  const std::vector<double> ct((size_t)B, ce / std::sqrt(1 - ab));
  Tensor out = combine(x0_hat, x_t, c0, ct);
  if (sigma > 0) {
    const Tensor z = rand_normal(x_t.shape(), gen, 0.0, 1.0, x_t.dtype());
    out = combine(out, z, std::vector<double>((size_t)B, 1.0), std::vector<double>((size_t)B, sigma));
  }
  return out;
}

std::vector<int64_t> sampling_timesteps(int64_t T, int64_t K) {
  if (K < 1 || K > T)
    throw Error("diffusion: " + std::to_string(K) + " sampling steps for a " + std::to_string(T) +
                "-step schedule (need 1 <= K <= T)");
  std::vector<int64_t> ts;
  for (int64_t k = 0; k < K; ++k)
    ts.push_back(K == 1 ? T - 1 : (int64_t)std::llround(double(T - 1) * double(K - 1 - k) / double(K - 1)));
  return ts;
}

}  // namespace t2m::casim
