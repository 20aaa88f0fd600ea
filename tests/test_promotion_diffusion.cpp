// test_promotion_diffusion.cpp — DDPM schedules of the PRO-Motion baseline: cosine and linear values, q(x_t | x_0)
// moments, the ancestral step's marginal consistency, and the sampler on a toy two-point distribution whose exact
// x_0 predictor is known in closed form.
#include <gtest/gtest.h>

#include <cmath>

#include "models/promotion/diffusion_schedule.h"
#include "tensor/ops.h"

namespace {

using namespace t2m;
using promotion::DiffusionSchedule;

const double kPi = 3.14159265358979323846;

TEST(DiffusionSchedule, CosineValues) {
  const int T = 100;
  const auto s = DiffusionSchedule::cosine(T);
  auto f = [&](double u) { return std::pow(std::cos((u / T + 0.008) / 1.008 * kPi / 2), 2); };
  // Before clipping, alpha_bar[t] = f(t + 1) / f(0) (Nichol & Dhariwal Eq 17).
  for (int t : {0, 1, 10, 49, 50, 90, 98}) EXPECT_NEAR(s.alpha_bar(t), f(t + 1) / f(0), 1e-12) << t;
  // Hand value: alpha_bar at the middle step = cos^2(0.508 / 1.008 * pi / 2) / cos^2(0.008 / 1.008 * pi / 2).
  EXPECT_NEAR(s.alpha_bar(49), 0.49385, 1e-4);  // 0.49377 / 0.99984
  EXPECT_NEAR(s.beta(0), 1 - f(1) / f(0), 1e-15);
  EXPECT_LT(s.beta(0), 1e-3);
  // f(T) = 0: the last beta is clipped at 0.999.
  EXPECT_DOUBLE_EQ(s.beta(T - 1), 0.999);
  EXPECT_NEAR(s.alpha_bar(T - 1), s.alpha_bar(T - 2) * 0.001, 1e-15);
  for (int t = 1; t < T; ++t) {
    EXPECT_LT(s.alpha_bar(t), s.alpha_bar(t - 1));
    EXPECT_GE(s.beta(t), s.beta(t - 1) - 1e-12);  // betas increase
  }
  EXPECT_EQ(s.alpha_bar(-1), 1.0);
  EXPECT_EQ(s.posterior_variance(0), 0.0);
}

TEST(DiffusionSchedule, LinearValues) {
  const auto s = DiffusionSchedule::linear(1000, 0.00085, 0.012);
  EXPECT_DOUBLE_EQ(s.beta(0), 0.00085);
  EXPECT_NEAR(s.beta(999), 0.012, 1e-15);
  EXPECT_NEAR(s.beta(500), 0.00085 + 0.01115 * 500 / 999, 1e-15);
  double p = 1;
  for (int t = 0; t < 1000; ++t) p *= 1 - s.beta(t);
  EXPECT_NEAR(s.alpha_bar(999), p, 1e-12);
  EXPECT_DOUBLE_EQ(DiffusionSchedule::linear(1, 0.1, 0.2).beta(0), 0.1);
}

TEST(DiffusionSchedule, QSampleIsTheClosedForm) {
  const auto s = DiffusionSchedule::cosine(100);
  Generator g(1);
  const Tensor x0 = rand_normal({3, 5}, g, 0, 1, DType::f64), eps = rand_normal({3, 5}, g, 0, 1, DType::f64);
  const Tensor t = Tensor::from_vector(std::vector<int64_t>{0, 42, 99}, {3});
  const Tensor xt = s.q_sample(x0, t, eps);
  for (int b = 0; b < 3; ++b) {
    const int tb = (int)t.at({b});
    for (int i = 0; i < 5; ++i)
      EXPECT_NEAR(xt.at({b, i}), std::sqrt(s.alpha_bar(tb)) * x0.at({b, i}) +
                                     std::sqrt(1 - s.alpha_bar(tb)) * eps.at({b, i}), 1e-12);
  }
}

// Starting from x_t ~ q(x_t | x_0) with the true x_0, one ancestral step gives x_{t-1} ~ q(x_{t-1} | x_0): mean
// sqrt(alpha_bar[t-1]) x_0 and variance 1 - alpha_bar[t-1] (checked on 200,000 draws).
TEST(DiffusionSchedule, AncestralStepKeepsTheMarginal) {
  const auto s = DiffusionSchedule::cosine(100);
  Generator g(5);
  const int64_t n = 200000;
  const double x0v = 0.7;
  for (int t : {1, 30, 80}) {
    const Tensor x0 = Tensor::full({n, 1}, x0v, DType::f64);
    const Tensor xt = s.q_sample(x0, Tensor::full({n}, t, DType::i64), rand_normal({n, 1}, g, 0, 1, DType::f64));
    const Tensor prev = s.ddpm_step(xt, x0, t, rand_normal({n, 1}, g, 0, 1, DType::f64));
    const double m = mean(prev).item();
    const double v = mean(square(add(prev, -m))).item();
    const double ab = s.alpha_bar(t - 1);
    EXPECT_NEAR(m, std::sqrt(ab) * x0v, 0.01) << t;
    EXPECT_NEAR(v, 1 - ab, 0.01) << t;
  }
  // The last step returns the x_0 estimate exactly (no noise).
  const Tensor x = Tensor::full({2, 2}, 3.0), x0h = Tensor::full({2, 2}, -1.0);
  EXPECT_FLOAT_EQ((float)s.ddpm_step(x, x0h, 0, Tensor()).at({1, 1}), -1.f);
}

// Toy data: x_0 = +1 with probability 0.75, -1 otherwise. Exact posterior mean:
// E[x_0 | x_t] = tanh(a x_t / (1 - ab) + atanh(0.5)), a = sqrt(ab). The sampler must reproduce the two points and
// their proportions.
TEST(DiffusionSchedule, SamplerOnToyTwoPointData) {
  const auto s = DiffusionSchedule::cosine(100);
  Generator g(9);
  const int64_t n = 4000;
  auto predict = [&](const Tensor& x, int t) {
    const double ab = s.alpha_bar(t), a = std::sqrt(ab);
    return tanh(add(mul(x, a / (1 - ab)), std::atanh(0.5)));
  };
  const Tensor out = promotion::ddpm_sample(s, {n, 1}, predict, g);
  const auto v = out.to_vector<float>();
  int pos = 0, near = 0;
  for (float x : v) {
    pos += x > 0;
    near += std::fabs(std::fabs(x) - 1) < 0.05;
  }
  EXPECT_NEAR((double)pos / n, 0.75, 0.03);
  EXPECT_GT((double)near / n, 0.98);
}

// DDIM with every step and eta = 1 is the DDPM ancestral sampler: same draws, same result.
TEST(DiffusionSchedule, DdimWithAllStepsAndEtaOneIsDdpm) {
  const auto s = DiffusionSchedule::linear(50, 0.00085, 0.012);
  auto predict = [&](const Tensor& x, int t) { return tanh(add(mul(x, 0.3 + 0.01 * t), 0.2)); };
  Generator g1(4), g2(4);
  const Tensor a = promotion::ddpm_sample(s, {64, 3}, predict, g1);
  const Tensor b = promotion::ddim_sample(s, {64, 3}, predict, g2, 50, 1.0);
  const auto va = a.to_vector<float>(), vb = b.to_vector<float>();
  for (size_t i = 0; i < va.size(); ++i) ASSERT_NEAR(va[i], vb[i], 1e-5) << i;
  EXPECT_EQ(g1.offset(), g2.offset());  // the same number of draws
}

TEST(DiffusionSchedule, DdimTimestepsAreStridedAndStartAtTheLast) {
  EXPECT_EQ(promotion::ddim_timesteps(1000, 4), (std::vector<int>{999, 749, 499, 249}));
  EXPECT_EQ(promotion::ddim_timesteps(5, 5), (std::vector<int>{4, 3, 2, 1, 0}));
  EXPECT_EQ(promotion::ddim_timesteps(10, 1), (std::vector<int>{9}));
  EXPECT_THROW(promotion::ddim_timesteps(10, 0), Error);
  EXPECT_THROW(promotion::ddim_timesteps(10, 11), Error);
}

// Deterministic DDIM (eta = 0) with an exact x_0 predictor lands on x_0 from any start and any stride; on the toy
// two-point data the strided stochastic sampler (eta = 1, 20 of 1000 steps) keeps the proportions.
TEST(DiffusionSchedule, StridedDdimOnToyData) {
  const auto s = DiffusionSchedule::linear(1000, 0.00085, 0.012);
  Generator g(3);
  const Tensor x0 = Tensor::full({8, 2}, 0.4);
  const Tensor det = promotion::ddim_sample(s, {8, 2}, [&](const Tensor&, int) { return x0; }, g, 7, 0.0);
  for (float v : det.to_vector<float>()) EXPECT_NEAR(v, 0.4f, 1e-6);
  const int64_t n = 4000;
  auto predict = [&](const Tensor& x, int t) {
    const double ab = s.alpha_bar(t), a = std::sqrt(ab);
    return tanh(add(mul(x, a / (1 - ab)), std::atanh(0.5)));
  };
  for (double eta : {0.0, 1.0}) {
    const auto v = promotion::ddim_sample(s, {n, 1}, predict, g, 20, eta).to_vector<float>();
    int pos = 0, near = 0;
    for (float x : v) {
      pos += x > 0;
      near += std::fabs(std::fabs(x) - 1) < 0.05;
    }
    EXPECT_NEAR((double)pos / n, 0.75, 0.03) << eta;
    EXPECT_GT((double)near / n, 0.97) << eta;
  }
  // ddim_step's bad input.
  const Tensor x = Tensor::zeros({2, 3});
  EXPECT_THROW(s.ddim_step(x, x, 5, 5, 1.0, x), Error);   // p must be < t
  EXPECT_THROW(s.ddim_step(x, x, 5, -2, 1.0, x), Error);
  EXPECT_THROW(s.ddim_step(x, x, 5, 2, 1.5, x), Error);   // eta outside [0, 1]
  EXPECT_THROW(s.ddim_step(x, x, 5, 2, 1.0, Tensor()), Error);  // noise needed
  EXPECT_THROW(promotion::ddim_sample(s, {2, 3}, [&](const Tensor& xt, int) { return xt; }, g, 0, 1.0), Error);
}

TEST(DiffusionSchedule, RejectsBadInput) {
  EXPECT_THROW(DiffusionSchedule::cosine(0), Error);
  EXPECT_THROW(DiffusionSchedule::linear(10, 0.0, 0.1), Error);
  EXPECT_THROW(DiffusionSchedule::linear(10, 0.1, 1.5), Error);
  EXPECT_THROW(DiffusionSchedule::cosine(10, -0.1), Error);
  const auto s = DiffusionSchedule::cosine(10);
  EXPECT_THROW(s.beta(10), Error);
  EXPECT_THROW(s.alpha_bar(-2), Error);
  const Tensor x = Tensor::zeros({2, 3});
  EXPECT_THROW(s.q_sample(x, Tensor::zeros({2}, DType::i64), Tensor::zeros({2, 4})), Error);
  EXPECT_THROW(s.q_sample(x, Tensor::zeros({3}, DType::i64), x), Error);
  EXPECT_THROW(s.q_sample(x, Tensor::full({2}, 10, DType::i64), x), Error);
  EXPECT_THROW(s.q_sample(x, Tensor::zeros({2}), x), Error);  // float steps
  EXPECT_THROW(s.ddpm_step(x, Tensor::zeros({2, 3}, DType::f64), 3, x), Error);
  EXPECT_THROW(s.ddpm_step(x, x, 3, Tensor()), Error);  // noise needed for t > 0
}

}  // namespace
