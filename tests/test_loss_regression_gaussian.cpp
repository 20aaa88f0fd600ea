// test_loss_regression_gaussian.cpp — MSE (nn/loss_regression.h) and the Gaussian KLs (nn/loss_gaussian.h):
// values against naive loops / closed forms / Monte Carlo, float64 gradchecks of every differentiable input,
// masking, and error messages.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "autograd/autograd.h"
#include "nn/loss_gaussian.h"
#include "nn/loss_regression.h"
#include "tensor/ops.h"
#include "tensor/rng.h"
#include "test_tensor_util.h"

namespace {

using namespace t2m;
using ag::Variable;
using VV = std::vector<Variable>;
using t2m::testing::expect_error;
using t2m::testing::random_tensor;
using t2m::testing::raw_values;

Variable var(const Tensor& t, bool grad = false) { return Variable(t, grad); }

void expect_gradcheck(const ag::GradcheckFn& f, const std::vector<Tensor>& in) {
  ag::GradcheckResult r = ag::gradcheck(f, in);
  EXPECT_TRUE(r.ok) << r.message;
}

// ---- MSE --------------------------------------------------------------------------------------------------

// Naive weighted MSE over (B, T, D) with per-frame weights w (B, T) (empty = all 1).
double naive_mse(const Tensor& p, const Tensor& t, const std::vector<double>& w, bool sum_last) {
  const int64_t B = p.size(0), T = p.size(1), D = p.size(2);
  double num = 0.0, den = 0.0;
  for (int64_t b = 0; b < B; ++b)
    for (int64_t f = 0; f < T; ++f) {
      const double wf = w.empty() ? 1.0 : w[b * T + f];
      for (int64_t d = 0; d < D; ++d) {
        const double e = p.at({b, f, d}) - t.at({b, f, d});
        num += wf * e * e;
      }
      den += wf * (sum_last ? 1.0 : (double)D);
    }
  return num / den;
}

TEST(MseLoss, MatchesNaiveMeanAndFrameNorm) {
  Tensor p = random_tensor({2, 4, 3}, DType::f64, 1), t = random_tensor({2, 4, 3}, DType::f64, 2);
  EXPECT_NEAR(nn::mse_loss(var(p), var(t)).item(), naive_mse(p, t, {}, false), 1e-14);
  nn::MseOptions o;
  o.sum_last_dim = true;
  EXPECT_NEAR(nn::mse_loss(var(p), var(t), o).item(), naive_mse(p, t, {}, true), 1e-13);
  std::vector<double> w = {1, 0.5, 0, 2, 1, 1, 0, 3};
  o.weights = Tensor::from_vector(w, {2, 4, 1});
  EXPECT_NEAR(nn::mse_loss(var(p), var(t), o).item(), naive_mse(p, t, w, true), 1e-13);
  o.sum_last_dim = false;
  EXPECT_NEAR(nn::mse_loss(var(p), var(t), o).item(), naive_mse(p, t, w, false), 1e-13);
  // float32 agrees with float64
  EXPECT_NEAR(nn::mse_loss(var(p.to(DType::f32)), var(t.to(DType::f32)), o).item(), naive_mse(p, t, w, false), 1e-5);
}

TEST(MseLoss, GradcheckPredAndTarget) {
  Tensor p = random_tensor({2, 3, 2}, DType::f64, 3), t = random_tensor({2, 3, 2}, DType::f64, 4);
  expect_gradcheck([](const VV& v) { return nn::mse_loss(v[0], v[1]); }, {p, t});
  nn::MseOptions o;
  o.sum_last_dim = true;
  o.weights = Tensor::from_vector(std::vector<double>{1, 0, 2}, {3, 1});  // broadcast over B
  expect_gradcheck([o](const VV& v) { return nn::mse_loss(v[0], v[1], o); }, {p, t});
}

TEST(MseLoss, MaskedFramesAreIgnored) {
  // (1, 4, 2): frames 2 and 3 are padding with huge values; the loss equals the loss on frames 0..1 alone.
  Tensor p = random_tensor({1, 4, 2}, DType::f64, 5), t = random_tensor({1, 4, 2}, DType::f64, 6);
  for (int64_t f = 2; f < 4; ++f)
    for (int64_t d = 0; d < 2; ++d) p.set({0, f, d}, 1e6 * (d + 1));
  nn::MseOptions o;
  o.weights = Tensor::from_vector(std::vector<int64_t>{1, 1, 0, 0}, {1, 4, 1});  // an int64 mask is accepted
  Variable vp = var(p, true);
  Variable loss = nn::mse_loss(vp, var(t), o);
  const double ref = nn::mse_loss(var(p.narrow(1, 0, 2)), var(t.narrow(1, 0, 2))).item();
  EXPECT_NEAR(loss.item(), ref, 1e-14);
  loss.backward();
  for (int64_t f = 0; f < 4; ++f)
    for (int64_t d = 0; d < 2; ++d) {
      if (f >= 2) {
        EXPECT_EQ(vp.grad().at({0, f, d}), 0.0);
      } else {
        EXPECT_NEAR(vp.grad().at({0, f, d}), 2.0 * (p.at({0, f, d}) - t.at({0, f, d})) / 4.0, 1e-14);
      }
    }
}

TEST(MseLoss, AllMaskedGivesZeroNotNaN) {
  Tensor p = random_tensor({2, 3}, DType::f64, 7), t = random_tensor({2, 3}, DType::f64, 8);
  nn::MseOptions o;
  o.weights = Tensor::zeros({2, 3}, DType::f64);
  Variable vp = var(p, true);
  Variable loss = nn::mse_loss(vp, var(t), o);
  EXPECT_EQ(loss.item(), 0.0);
  loss.backward();
  for (double g : raw_values(vp.grad())) EXPECT_EQ(g, 0.0);
}

TEST(MseLoss, BadUseThrows) {
  Tensor a = Tensor::zeros({2, 3}, DType::f64), b = Tensor::zeros({3, 2}, DType::f64);
  expect_error([&] { nn::mse_loss(var(a), var(b)); }, {"mse_loss", "[2, 3]", "[3, 2]"});
  expect_error([&] { nn::mse_loss(var(a), var(a.to(DType::f32))); }, {"mse_loss", "f32"});
  nn::MseOptions o;
  o.weights = Tensor::ones({4}, DType::f64);
  expect_error([&] { nn::mse_loss(var(a), var(a), o); }, {"mse_loss", "weights", "[4]", "[2, 3]"});
  o.weights = Tensor::from_vector(std::vector<double>{1, -1}, {2, 1});
  expect_error([&] { nn::mse_loss(var(a), var(a), o); }, {"mse_loss", ">= 0", "-1"});
  o.weights = Tensor::ones({2, 3}, DType::f64);
  o.sum_last_dim = true;
  expect_error([&] { nn::mse_loss(var(a), var(a), o); }, {"mse_loss", "per frame", "[2, 3]"});
}

// ---- KL(N(mu, e^logvar) || N(0, I)) (Eq 6) ---------------------------------------------------------------------

TEST(KlStandardNormal, ZeroAtThePriorAndPositiveElsewhere) {
  Tensor z = Tensor::zeros({2, 3, 4}, DType::f64);
  EXPECT_EQ(nn::kl_standard_normal(var(z), var(z)).item(), 0.0);
  EXPECT_GT(nn::kl_standard_normal(var(random_tensor({2, 3, 4}, DType::f64, 9)), var(z)).item(), 0.0);
  EXPECT_GT(nn::kl_standard_normal(var(z), var(random_tensor({2, 3, 4}, DType::f64, 10))).item(), 0.0);
}

TEST(KlStandardNormal, ReductionsMatchClosedForm) {
  Tensor mu = random_tensor({2, 3, 4}, DType::f64, 11), lv = random_tensor({2, 3, 4}, DType::f64, 12);
  const std::vector<double> m = raw_values(mu), l = raw_values(lv);
  double total = 0.0, anchor = 0.0;
  for (size_t e = 0; e < m.size(); ++e) {
    total += 0.5 * (m[e] * m[e] + std::exp(l[e]) - 1.0 - l[e]);
    anchor += 1.0 + l[e] - m[e] * m[e] - std::exp(l[e]);
  }
  anchor = -0.5 * anchor / (double)m.size();  // torch_ref.py: -0.5 * mean(1 + logvar - mu^2 - exp(logvar))
  EXPECT_NEAR(nn::kl_standard_normal(var(mu), var(lv)).item(), anchor, 1e-14);
  EXPECT_NEAR(nn::kl_standard_normal(var(mu), var(lv), nn::KlReduction::sum).item(), total, 1e-12);
  EXPECT_NEAR(nn::kl_standard_normal(var(mu), var(lv), nn::KlReduction::batch_mean).item(), total / 2.0, 1e-12);
  // Mask the last latent frame (dim 2) of sample 1: those elements drop out of the sum.
  Tensor w = Tensor::ones({2, 1, 4}, DType::f64);
  w.set({1, 0, 3}, 0.0);
  double masked = 0.0;
  for (int64_t b = 0; b < 2; ++b)
    for (int64_t c = 0; c < 3; ++c)
      for (int64_t t = 0; t < 4; ++t)
        if (!(b == 1 && t == 3)) {
          const double a = mu.at({b, c, t}), v = lv.at({b, c, t});
          masked += 0.5 * (a * a + std::exp(v) - 1.0 - v);
        }
  EXPECT_NEAR(nn::kl_standard_normal(var(mu), var(lv), nn::KlReduction::sum, w).item(), masked, 1e-12);
  EXPECT_NEAR(nn::kl_standard_normal(var(mu), var(lv), nn::KlReduction::mean_elements, w).item(), masked / 21.0,
              1e-13);
}

TEST(KlStandardNormal, GradcheckMuAndLogvar) {
  Tensor mu = random_tensor({2, 2, 3}, DType::f64, 13), lv = random_tensor({2, 2, 3}, DType::f64, 14, -1.0, 1.0);
  for (auto r : {nn::KlReduction::mean_elements, nn::KlReduction::batch_mean, nn::KlReduction::sum})
    expect_gradcheck([r](const VV& v) { return nn::kl_standard_normal(v[0], v[1], r); }, {mu, lv});
  Tensor w = Tensor::from_vector(std::vector<double>{1, 1, 0}, {1, 1, 3});
  expect_gradcheck([w](const VV& v) { return nn::kl_standard_normal(v[0], v[1], nn::KlReduction::batch_mean, w); },
                   {mu, lv});
}

TEST(KlStandardNormal, BadUseThrows) {
  Tensor a = Tensor::zeros({2, 3}, DType::f64);
  expect_error([&] { nn::kl_standard_normal(var(a), var(Tensor::zeros({3, 2}, DType::f64))); },
               {"kl_standard_normal", "[2, 3]", "[3, 2]"});
  expect_error([&] { nn::kl_standard_normal(var(a), var(a), nn::KlReduction::sum, Tensor::ones({5})); },
               {"kl_standard_normal", "weights", "[5]"});
  Tensor s = Tensor::zeros({}, DType::f64);
  expect_error([&] { nn::kl_standard_normal(var(s), var(s), nn::KlReduction::batch_mean); },
               {"kl_standard_normal", "batch_mean", "0-d"});
}

// ---- KL between diagonal Gaussians (Eq 5 / Eq 21) ------------------------------------------------------------

double kl1(double m1, double s1, double m2, double s2) {  // KL(N(m1, s1²) || N(m2, s2²)), s = std
  return std::log(s2 / s1) + (s1 * s1 + (m1 - m2) * (m1 - m2)) / (2.0 * s2 * s2) - 0.5;
}

TEST(KlDiagGaussians, EqualGaussiansGiveZero) {
  Tensor mu = random_tensor({3, 5, 4}, DType::f64, 15), ls = random_tensor({3, 5, 4}, DType::f64, 16, -1.0, 1.0);
  Variable kl = nn::kl_diag_gaussians(var(mu), var(ls), var(mu), var(ls));
  ASSERT_EQ(kl.shape(), (Shape{3, 5}));
  for (double v : raw_values(kl.data())) EXPECT_NEAR(v, 0.0, 1e-14);
}

TEST(KlDiagGaussians, ClosedFormBothParametrisationsAndOrder) {
  // 1-D: KL(N(1, 2²) || N(0, 1)) = log(1/2) + (4 + 1)/2 - 1/2 = 2 - log 2.
  auto one = [](double v) { return Tensor::from_vector(std::vector<double>{v}, {1}); };
  EXPECT_NEAR(nn::kl_diag_gaussians(var(one(1)), var(one(std::log(2.0))), var(one(0)), var(one(0))).item(),
              2.0 - std::log(2.0), 1e-14);
  // Reverse order: KL(N(0, 1) || N(1, 2²)) = log 2 + (1 + 1)/8 - 1/2 (KL is not symmetric; order is p || q).
  EXPECT_NEAR(nn::kl_diag_gaussians(var(one(0)), var(one(0)), var(one(1)), var(one(std::log(2.0)))).item(),
              std::log(2.0) + 0.25 - 0.5, 1e-14);
  // Random (B, T, A): per-coordinate sum against the textbook formula; log_var = 2 log_std gives the same.
  Tensor m1 = random_tensor({2, 3, 4}, DType::f64, 17), m2 = random_tensor({2, 3, 4}, DType::f64, 18);
  Tensor l1 = random_tensor({2, 3, 4}, DType::f64, 19, -1, 1), l2 = random_tensor({2, 3, 4}, DType::f64, 20, -1, 1);
  Variable kl = nn::kl_diag_gaussians(var(m1), var(l1), var(m2), var(l2));
  Variable klv = nn::kl_diag_gaussians(var(m1), var(mul(l1, 2.0)), var(m2), var(mul(l2, 2.0)),
                                       nn::GaussianScale::log_var);
  for (int64_t b = 0; b < 2; ++b)
    for (int64_t t = 0; t < 3; ++t) {
      double ref = 0.0;
      for (int64_t a = 0; a < 4; ++a)
        ref += kl1(m1.at({b, t, a}), std::exp(l1.at({b, t, a})), m2.at({b, t, a}), std::exp(l2.at({b, t, a})));
      EXPECT_NEAR(kl.data().at({b, t}), ref, 1e-13);
      EXPECT_NEAR(klv.data().at({b, t}), ref, 1e-13);
    }
}

TEST(KlDiagGaussians, MonteCarloAgreesWithClosedForm) {
  // E_{x~p}[log p(x) - log q(x)] over 200k Philox draws of a 3-D Gaussian.
  const std::vector<double> m1 = {0.3, -0.5, 1.0}, s1 = {0.7, 1.2, 0.4}, m2 = {0.0, 0.2, 0.8}, s2 = {1.0, 0.9, 0.6};
  Generator gen(42);
  const int64_t N = 200000;
  Tensor n = rand_normal({N, 3}, gen, 0.0, 1.0, DType::f64);
  const double* pn = n.data<double>();
  double acc = 0.0;
  for (int64_t i = 0; i < N; ++i)
    for (int a = 0; a < 3; ++a) {
      const double x = m1[a] + s1[a] * pn[i * 3 + a];
      const double lp = -std::log(s1[a]) - 0.5 * std::pow((x - m1[a]) / s1[a], 2);
      const double lq = -std::log(s2[a]) - 0.5 * std::pow((x - m2[a]) / s2[a], 2);
      acc += lp - lq;
    }
  auto logs = [](std::vector<double> s) {
    for (double& v : s) v = std::log(v);
    return Tensor::from_vector(s, {3});
  };
  const double kl = nn::kl_diag_gaussians(var(Tensor::from_vector(m1, {3})), var(logs(s1)),
                                          var(Tensor::from_vector(m2, {3})), var(logs(s2))).item();
  EXPECT_NEAR(acc / (double)N, kl, 0.02);  // MC std error here is ~0.004
}

TEST(KlDiagGaussians, GradcheckAllInputsIncludingBroadcastScale) {
  Tensor m1 = random_tensor({2, 2, 3}, DType::f64, 21), m2 = random_tensor({2, 2, 3}, DType::f64, 22);
  Tensor l1 = random_tensor({2, 2, 3}, DType::f64, 23, -1, 1), l2 = random_tensor({2, 2, 3}, DType::f64, 24, -1, 1);
  for (auto p : {nn::GaussianScale::log_std, nn::GaussianScale::log_var})
    expect_gradcheck([p](const VV& v) { return nn::kl_diag_gaussians(v[0], v[1], v[2], v[3], p); }, {m1, l1, m2, l2});
  // A fixed per-action log std (A,) shared by every frame (Meta Motivo-style actor), and a 0-d one.
  Tensor la = random_tensor({3}, DType::f64, 25, -1, 1);
  expect_gradcheck([](const VV& v) { return nn::kl_diag_gaussians(v[0], v[1], v[2], v[3]); },
                   {m1, la, m2, Tensor::scalar(-0.3, DType::f64)});
}

TEST(KlDiagGaussians, ActionKlMetricAveragesValidFrames) {
  Tensor m1 = random_tensor({2, 3, 4}, DType::f64, 26), m2 = random_tensor({2, 3, 4}, DType::f64, 27);
  Tensor ls = Tensor::full({4}, std::log(0.2), DType::f64);
  Tensor kl = nn::kl_diag_gaussians(var(m1), var(ls), var(m2), var(ls)).data();  // (2, 3)
  // Equal std σ: KL = ||m1 - m2||² / (2 σ²).
  double all = 0.0, valid = 0.0;
  for (int64_t b = 0; b < 2; ++b)
    for (int64_t t = 0; t < 3; ++t) {
      double d2 = 0.0;
      for (int64_t a = 0; a < 4; ++a) d2 += std::pow(m1.at({b, t, a}) - m2.at({b, t, a}), 2);
      EXPECT_NEAR(kl.at({b, t}), d2 / (2.0 * 0.04), 1e-11);
      all += kl.at({b, t});
      if (t < 2 || b == 0) valid += kl.at({b, t});
    }
  EXPECT_NEAR(nn::action_kl(m1, ls, m2, ls), all / 6.0, 1e-12);
  Tensor mask = Tensor::ones({2, 3}, DType::f64);
  mask.set({1, 2}, 0.0);  // sample 1 is one frame shorter
  EXPECT_NEAR(nn::action_kl(m1, ls, m2, ls, nn::GaussianScale::log_std, mask), valid / 5.0, 1e-12);
  EXPECT_EQ(nn::action_kl(m1, ls, m1, ls), 0.0);
}

TEST(KlDiagGaussians, LargeValuesStayFinite) {
  Tensor m1 = Tensor::full({2, 3}, 1e3, DType::f32), m2 = Tensor::full({2, 3}, -1e3, DType::f32);
  Tensor l1 = Tensor::full({2, 3}, -20.0, DType::f32), l2 = Tensor::full({2, 3}, 20.0, DType::f32);
  for (double v : raw_values(nn::kl_diag_gaussians(var(m1), var(l1), var(m2), var(l2)).data()))
    EXPECT_TRUE(std::isfinite(v));
}

TEST(KlDiagGaussians, BadUseThrows) {
  Tensor a = Tensor::zeros({2, 3}, DType::f64), b = Tensor::zeros({2, 4}, DType::f64);
  expect_error([&] { nn::kl_diag_gaussians(var(a), var(a), var(b), var(b)); },
               {"kl_diag_gaussians", "mu1", "[2, 3]", "[2, 4]"});
  expect_error([&] { nn::kl_diag_gaussians(var(a), var(Tensor::zeros({4}, DType::f64)), var(a), var(a)); },
               {"kl_diag_gaussians", "scale1", "[4]"});
  Tensor s = Tensor::zeros({}, DType::f64);
  expect_error([&] { nn::kl_diag_gaussians(var(s), var(s), var(s), var(s)); }, {"kl_diag_gaussians", "0-d"});
  expect_error([&] { nn::action_kl(a, a, a, a, nn::GaussianScale::log_std, Tensor::ones({3})); },
               {"action_kl", "weights", "[3]", "[2]"});
}

}  // namespace
