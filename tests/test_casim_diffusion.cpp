// test_casim_diffusion.cpp — the CASIM-MDM diffusion process: cosine schedule values, q(x_t | x_0) statistics, the
// DDIM/DDPM reverse step (DDPM posterior identity), samplers on toy data, classifier-free guidance.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "models/casim/diffusion_sampler.h"
#include "models/casim/diffusion_schedule.h"
#include "tensor/ops.h"

using namespace t2m;
using namespace t2m::casim;

TEST(CasimSchedule, CosineValuesAndMonotone) {
  const DiffusionSchedule s = cosine_schedule(1000);
  ASSERT_EQ(s.steps, 1000);
  ASSERT_EQ(s.alpha_bar.size(), 1000u);
  for (size_t t = 1; t < s.alpha_bar.size(); ++t) EXPECT_LT(s.alpha_bar[t], s.alpha_bar[t - 1]) << t;
  // endpoints: alpha_bar_0 = f(1/T)/f(0); f(u) = cos^2(((u + s)/(1 + s)) pi/2)
  auto f = [](double u) { const double c = std::cos((u + 0.008) / 1.008 * std::numbers::pi / 2); return c * c; };
  EXPECT_NEAR(s.alpha_bar[0], f(0.001) / f(0), 1e-12);
  EXPECT_GT(s.alpha_bar[0], 0.9999);
  EXPECT_LT(s.alpha_bar[999], 1e-6);
  // the middle follows the closed form alpha_bar_t = f((t+1)/T) / f(0) where no beta is clipped
  EXPECT_NEAR(s.alpha_bar[499], f(0.5) / f(0), 1e-9);
  for (double b : s.beta) EXPECT_LE(b, 0.999);
  EXPECT_EQ(s.ab(-1), 1.0);
  EXPECT_THROW(s.ab(1000), Error);
  EXPECT_THROW(cosine_schedule(1), Error);
  EXPECT_THROW(cosine_schedule(100, 0.0), Error);
}

TEST(CasimSchedule, ForwardProcessStatistics) {
  const DiffusionSchedule s = cosine_schedule(1000);
  const int64_t B = 3, n = 20000;
  Tensor x0 = Tensor::empty({B, n}, DType::f64);
  for (int64_t i = 0; i < B * n; ++i) x0.data<double>()[i] = 2.0;
  const Tensor t = Tensor::from_vector(std::vector<int64_t>{0, 500, 999}, {B});
  Generator g(3);
  const Tensor eps = rand_normal({B, n}, g, 0, 1, DType::f64);
  const Tensor xt = q_sample(s, x0, t, eps);
  const int64_t ts[3] = {0, 500, 999};
  for (int64_t b = 0; b < B; ++b) {
    double m = 0, v = 0;
    for (int64_t k = 0; k < n; ++k) m += xt.data<double>()[b * n + k];
    m /= n;
    for (int64_t k = 0; k < n; ++k) v += std::pow(xt.data<double>()[b * n + k] - m, 2);
    v /= n;
    const double ab = s.alpha_bar[(size_t)ts[b]];
    EXPECT_NEAR(m, 2.0 * std::sqrt(ab), 0.03) << b;
    EXPECT_NEAR(v, 1 - ab, 0.03) << b;
  }
  // exact per element
  EXPECT_NEAR(xt.data<double>()[n + 5], std::sqrt(s.alpha_bar[500]) * 2 + std::sqrt(1 - s.alpha_bar[500]) * eps.data<double>()[n + 5], 1e-12);
  EXPECT_THROW(q_sample(s, x0, Tensor::from_vector(std::vector<int64_t>{0, 1, 1000}, {B}), eps), Error);
  EXPECT_THROW(q_sample(s, x0, Tensor::from_vector(std::vector<int64_t>{0, 1}, {2}), eps), Error);
}

TEST(CasimSchedule, SamplingTimesteps) {
  EXPECT_EQ(sampling_timesteps(1000, 1), (std::vector<int64_t>{999}));
  EXPECT_EQ(sampling_timesteps(1000, 4), (std::vector<int64_t>{999, 666, 333, 0}));
  const auto all = sampling_timesteps(10, 10);
  for (int64_t k = 0; k < 10; ++k) EXPECT_EQ(all[(size_t)k], 9 - k);
  EXPECT_THROW(sampling_timesteps(10, 11), Error);
  EXPECT_THROW(sampling_timesteps(10, 0), Error);
}

TEST(CasimSchedule, DdpmStepIsThePosterior) {
  // eta = 1 from t to t-1: mean = sqrt(ap) beta/(1-ab) x0 + sqrt(1-beta)(1-ap)/(1-ab) x_t, var = beta (1-ap)/(1-ab)
  const DiffusionSchedule s = cosine_schedule(100);
  const int64_t t = 40, n = 40000;
  const double ab = s.alpha_bar[t], ap = s.alpha_bar[t - 1], beta = s.beta[t];
  Tensor xt = Tensor::full({1, n}, 0.7, DType::f64), x0 = Tensor::full({1, n}, -1.3, DType::f64);
  Generator g(5);
  const Tensor out = reverse_step(s, xt, x0, t, t - 1, 1.0, g);
  double m = 0, v = 0;
  for (int64_t k = 0; k < n; ++k) m += out.data<double>()[k];
  m /= n;
  for (int64_t k = 0; k < n; ++k) v += std::pow(out.data<double>()[k] - m, 2);
  v /= n;
  const double mean = std::sqrt(ap) * beta / (1 - ab) * -1.3 + std::sqrt(1 - beta) * (1 - ap) / (1 - ab) * 0.7;
  const double var = beta * (1 - ap) / (1 - ab);
  EXPECT_NEAR(m, mean, 4 * std::sqrt(var / n) + 1e-9);
  EXPECT_NEAR(v, var, 0.05 * var);
  // eta = 0: deterministic, no noise drawn; x_t consistent with x0 and eps stays on that line.
  Generator g2(9);
  const Tensor a = reverse_step(s, xt, x0, t, 10, 0.0, g2);
  EXPECT_EQ(g2.offset(), 0u);
  const double eps = (0.7 - std::sqrt(ab) * -1.3) / std::sqrt(1 - ab);
  EXPECT_NEAR(a.data<double>()[3], std::sqrt(s.alpha_bar[10]) * -1.3 + std::sqrt(1 - s.alpha_bar[10]) * eps, 1e-12);
  // the final step returns x0
  const Tensor fin = reverse_step(s, xt, x0, 0, -1, 1.0, g2);
  EXPECT_NEAR(fin.data<double>()[0], -1.3, 1e-12);
  EXPECT_THROW(reverse_step(s, xt, x0, 10, 10, 0.0, g2), Error);
  EXPECT_THROW(reverse_step(s, xt, x0, 10, 5, -1.0, g2), Error);
  EXPECT_THROW(reverse_step(s, xt, Tensor::zeros({1, 3}, DType::f64), 10, 5, 0.0, g2), Error);
}

TEST(CasimSampler, PerfectPredictorRecoversAFixedTarget) {
  const DiffusionSchedule s = cosine_schedule(1000);
  const Tensor target = Tensor::from_vector(std::vector<double>{0.5, -2.0, 1.25, 3.0}, {2, 2});
  for (double eta : {0.0, 1.0}) {
    Generator g(11);
    const Tensor xT = rand_normal({2, 2}, g, 0, 1, DType::f64);
    SamplerOptions o;
    o.steps = 20, o.eta = eta;
    const Tensor out = diffusion_sample(s, [&](const Tensor&, int64_t) { return target; }, xT, o, g);
    for (int64_t i = 0; i < 4; ++i) EXPECT_NEAR(out.data<double>()[i], target.data<double>()[i], 1e-9) << eta;
  }
}

// 1-D two-component Gaussian mixture 0.5 N(-2, s0^2) + 0.5 N(2, s0^2): the exact posterior mean E[x0 | x_t] is the
// optimal x0-predictor; DDPM sampling with it must reproduce the mixture.
TEST(CasimSampler, DdpmOnAGaussianMixtureWithTheExactPredictor) {
  const DiffusionSchedule s = cosine_schedule(1000);
  const double mu = 2.0, s0 = 0.3;
  auto x0_fn = [&](const Tensor& x, int64_t t) {
    const double ab = s.alpha_bar[(size_t)t], a = std::sqrt(ab);
    const double var = ab * s0 * s0 + (1 - ab);
    Tensor out = Tensor::empty(x.shape(), DType::f64);
    for (int64_t i = 0; i < x.numel(); ++i) {
      const double xv = x.data<double>()[i];
      double w[2], m[2];
      for (int k = 0; k < 2; ++k) {
        const double c = k ? mu : -mu;
        w[k] = -0.5 * std::pow(xv - a * c, 2) / var;
        m[k] = c + a * s0 * s0 / var * (xv - a * c);  // E[x0 | x_t, component k]
      }
      const double mx = std::max(w[0], w[1]);
      const double p1 = std::exp(w[1] - mx) / (std::exp(w[0] - mx) + std::exp(w[1] - mx));
      out.data<double>()[i] = (1 - p1) * m[0] + p1 * m[1];
    }
    return out;
  };
  Generator g(2);
  const int64_t n = 4000;
  const Tensor xT = rand_normal({n, 1}, g, 0, 1, DType::f64);
  SamplerOptions o;
  o.steps = 100, o.eta = 1.0;
  const Tensor out = diffusion_sample(s, x0_fn, xT, o, g);
  int pos = 0;
  double dev = 0;
  for (int64_t i = 0; i < n; ++i) {
    const double v = out.data<double>()[i];
    pos += v > 0;
    dev += std::pow(std::abs(v) - mu, 2);
  }
  EXPECT_NEAR(double(pos) / n, 0.5, 0.05);
  EXPECT_NEAR(std::sqrt(dev / n), s0, 0.08);  // the spread of each mode, not collapsed onto the means
}

TEST(CasimSampler, GuidanceWeights) {
  const Tensor c = Tensor::from_vector(std::vector<float>{1, 2, 3}, {1, 3});
  const Tensor u = Tensor::from_vector(std::vector<float>{0, 0, 1}, {1, 3});
  const Tensor g1 = guided_x0(c, u, 1.0), g0 = guided_x0(c, u, 0.0), g2 = guided_x0(c, u, 2.5);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(g1.data<float>()[i], c.data<float>()[i]);
    EXPECT_FLOAT_EQ(g0.data<float>()[i], u.data<float>()[i]);
    EXPECT_FLOAT_EQ(g2.data<float>()[i], u.data<float>()[i] + 2.5f * (c.data<float>()[i] - u.data<float>()[i]));
  }
  EXPECT_THROW(guided_x0(c, u, NAN), Error);
}

TEST(CasimSampler, WrongPredictorShapeThrows) {
  const DiffusionSchedule s = cosine_schedule(10);
  Generator g(1);
  SamplerOptions o;
  o.steps = 3;
  EXPECT_THROW(diffusion_sample(s, [](const Tensor&, int64_t) { return Tensor::zeros({3}); }, Tensor::zeros({2, 2}), o, g),
               Error);
}
