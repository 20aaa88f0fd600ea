// test_loss_flow_classification.cpp — flow matching (nn/loss_flow.h, Eq 14–15) and cross-entropy / accuracy
// (nn/loss_classification.h): values against naive loops, float64 gradchecks, masking / ignore_index, large
// logits, determinism of the time sampler, and error messages.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "autograd/autograd.h"
#include "nn/loss_classification.h"
#include "nn/loss_flow.h"
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

// ---- flow matching ----------------------------------------------------------------------------------------------

TEST(FlowMatching, InterpolateFollowsTheLinearPath) {
  Tensor x0 = random_tensor({3, 2, 4}, DType::f64, 1), x1 = random_tensor({3, 2, 4}, DType::f64, 2);
  Tensor t = Tensor::from_vector(std::vector<double>{0.0, 0.25, 1.0}, {3});
  nn::FlowPoint p = nn::flow_interpolate(var(x0), var(x1), var(t));
  ASSERT_EQ(p.x_t.shape(), x0.shape());
  for (int64_t b = 0; b < 3; ++b)
    for (int64_t i = 0; i < 2; ++i)
      for (int64_t d = 0; d < 4; ++d) {
        const double a = x0.at({b, i, d}), c = x1.at({b, i, d}), tb = t.at({b});
        EXPECT_NEAR(p.x_t.data().at({b, i, d}), (1.0 - tb) * a + tb * c, 1e-15);  // Eq 14
        EXPECT_NEAR(p.velocity.data().at({b, i, d}), c - a, 1e-15);              // Eq 15 target
      }
  // t = 0 is the noise and t = 1 the data, exactly.
  EXPECT_EQ(p.x_t.data().at({0, 1, 2}), x0.at({0, 1, 2}));
  EXPECT_EQ(p.x_t.data().at({2, 1, 2}), x1.at({2, 1, 2}));
  // One shared t.
  nn::FlowPoint q = nn::flow_interpolate(var(x0), var(x1), var(Tensor::scalar(0.5, DType::f64)));
  EXPECT_NEAR(q.x_t.data().at({1, 0, 3}), 0.5 * (x0.at({1, 0, 3}) + x1.at({1, 0, 3})), 1e-15);
}

TEST(FlowMatching, GradcheckInterpolationAndLoss) {
  Tensor x0 = random_tensor({2, 3, 2}, DType::f64, 3), x1 = random_tensor({2, 3, 2}, DType::f64, 4);
  Tensor t = Tensor::from_vector(std::vector<double>{0.3, 0.8}, {2});
  expect_gradcheck([](const VV& v) { return nn::flow_interpolate(v[0], v[1], v[2]).x_t; }, {x0, x1, t});
  Tensor v = random_tensor({2, 3, 2}, DType::f64, 5);
  expect_gradcheck([](const VV& a) { return nn::flow_matching_loss(a[0], a[1], a[2]); }, {v, x0, x1});
  nn::MseOptions o;
  o.sum_last_dim = true;
  o.weights = Tensor::from_vector(std::vector<double>{1, 1, 0, 1, 0, 0}, {2, 3, 1});
  expect_gradcheck([o](const VV& a) { return nn::flow_matching_loss(a[0], a[1], a[2], o); }, {v, x0, x1});
}

TEST(FlowMatching, LossValuesMaskAndPerfectPrediction) {
  Tensor x0 = random_tensor({2, 3, 4}, DType::f64, 6), x1 = random_tensor({2, 3, 4}, DType::f64, 7);
  Tensor v = random_tensor({2, 3, 4}, DType::f64, 8);
  double all = 0.0, masked = 0.0;
  for (int64_t b = 0; b < 2; ++b)
    for (int64_t f = 0; f < 3; ++f)
      for (int64_t d = 0; d < 4; ++d) {
        const double e = v.at({b, f, d}) - (x1.at({b, f, d}) - x0.at({b, f, d}));
        all += e * e;
        if (!(b == 1 && f == 2)) masked += e * e;
      }
  EXPECT_NEAR(nn::flow_matching_loss(var(v), var(x0), var(x1)).item(), all / 24.0, 1e-14);  // F.mse_loss
  nn::MseOptions o;
  o.sum_last_dim = true;
  EXPECT_NEAR(nn::flow_matching_loss(var(v), var(x0), var(x1), o).item(), all / 6.0, 1e-13);  // Eq 15 per frame
  o.weights = Tensor::ones({2, 3, 1}, DType::f64);
  o.weights.set({1, 2, 0}, 0.0);
  EXPECT_NEAR(nn::flow_matching_loss(var(v), var(x0), var(x1), o).item(), masked / 5.0, 1e-13);
  EXPECT_EQ(nn::flow_matching_loss(var(sub(x1, x0)), var(x0), var(x1)).item(), 0.0);
}

TEST(FlowMatching, TimeSamplingIsDeterministicAndInRange) {
  Generator g1(7), g2(7), g3(8);
  Tensor a = nn::sample_flow_time(4096, g1), b = nn::sample_flow_time(4096, g2), c = nn::sample_flow_time(4096, g3);
  EXPECT_EQ(max_abs_diff(a, b), 0.0);
  EXPECT_GT(max_abs_diff(a, c), 0.1);
  EXPECT_EQ(g1.offset(), g2.offset());
  const std::vector<double> u = raw_values(a);
  double mean = 0.0, below_quarter = 0.0;
  for (double x : u) {
    EXPECT_GE(x, 0.0);
    EXPECT_LT(x, 1.0);
    mean += x;
    below_quarter += x < 0.25 ? 1.0 : 0.0;
  }
  EXPECT_NEAR(mean / 4096.0, 0.5, 0.02);
  EXPECT_NEAR(below_quarter / 4096.0, 0.25, 0.02);
  // logit-normal(0, 1): in (0, 1), median 0.5, mass concentrated in the middle (P(t < 0.25) = Φ(logit 0.25) ≈ 0.136).
  nn::FlowTimeOptions ln;
  ln.kind = nn::FlowTimeSampling::logit_normal;
  Generator g4(9);
  const std::vector<double> l = raw_values(nn::sample_flow_time(8192, g4, ln, DType::f64));
  double below_half = 0.0, low = 0.0;
  for (double x : l) {
    EXPECT_GT(x, 0.0);
    EXPECT_LT(x, 1.0);
    below_half += x < 0.5 ? 1.0 : 0.0;
    low += x < 0.25 ? 1.0 : 0.0;
  }
  EXPECT_NEAR(below_half / 8192.0, 0.5, 0.02);
  EXPECT_NEAR(low / 8192.0, 0.5 * std::erfc(std::log(3.0) / std::sqrt(2.0)), 0.015);
}

TEST(FlowMatching, SamplePairIsConsistentAndReproducible) {
  Tensor x1 = random_tensor({3, 5, 2}, DType::f32, 10);
  Generator g1(11), g2(11);
  nn::FlowSample s = nn::sample_flow_pair(x1, g1), r = nn::sample_flow_pair(x1, g2);
  EXPECT_EQ(max_abs_diff(s.x_t, r.x_t), 0.0);
  EXPECT_EQ(s.t.shape(), (Shape{3}));
  EXPECT_LT(max_abs_diff(s.velocity, sub(x1, s.x0)), 1e-6);
  EXPECT_LT(max_abs_diff(s.x_t, add(s.x0, mul(s.t.view({3, 1, 1}), s.velocity))), 1e-5);
}

TEST(FlowMatching, BadUseThrows) {
  Tensor a = Tensor::zeros({2, 3}, DType::f64), b = Tensor::zeros({3, 3}, DType::f64);
  expect_error([&] { nn::flow_interpolate(var(a), var(b), var(Tensor::zeros({2}, DType::f64))); },
               {"flow_interpolate", "[2, 3]", "[3, 3]"});
  expect_error([&] { nn::flow_interpolate(var(a), var(a), var(Tensor::zeros({3}, DType::f64))); },
               {"flow_interpolate", "t must be (B,)", "[3]"});
  expect_error([&] { nn::flow_matching_loss(var(b), var(a), var(a)); }, {"mse_loss", "[3, 3]", "[2, 3]"});
  Generator g(1);
  nn::FlowTimeOptions o;
  o.kind = nn::FlowTimeSampling::logit_normal;
  o.std = -1.0;
  expect_error([&] { nn::sample_flow_time(4, g, o); }, {"sample_flow_time", "std"});
  expect_error([&] { nn::sample_flow_time(-1, g); }, {"sample_flow_time", "-1"});
}

// ---- cross-entropy and accuracy ---------------------------------------------------------------------------------

// Naive: mean over non-ignored rows of (1 - eps)(-log p_y) + eps * mean_c(-log p_c), logits (N, C).
double naive_ce(const Tensor& z, const std::vector<int64_t>& y, int64_t ignore, double eps) {
  const int64_t N = z.size(0), C = z.size(1);
  double total = 0.0;
  int64_t n_valid = 0;
  for (int64_t n = 0; n < N; ++n) {
    if (y[n] == ignore) continue;
    double mx = -1e300;
    for (int64_t c = 0; c < C; ++c) mx = std::max(mx, z.at({n, c}));
    double se = 0.0;
    for (int64_t c = 0; c < C; ++c) se += std::exp(z.at({n, c}) - mx);
    const double lse = mx + std::log(se);
    double smooth = 0.0;
    for (int64_t c = 0; c < C; ++c) smooth += (lse - z.at({n, c})) / (double)C;
    total += (1.0 - eps) * (lse - z.at({n, y[n]})) + eps * smooth;
    ++n_valid;
  }
  return total / (double)n_valid;
}

TEST(CrossEntropy, MatchesNaiveWithSmoothingAndIgnore) {
  Tensor z = random_tensor({5, 4}, DType::f64, 12, -3, 3);
  const std::vector<int64_t> y = {2, 0, -100, 3, 1};
  Tensor ty = Tensor::from_vector(y, {5});
  EXPECT_NEAR(nn::cross_entropy(var(z), ty).item(), naive_ce(z, y, -100, 0.0), 1e-14);
  nn::CrossEntropyOptions o;
  o.label_smoothing = 0.1;
  EXPECT_NEAR(nn::cross_entropy(var(z), ty, o).item(), naive_ce(z, y, -100, 0.1), 1e-14);
  o.ignore_index = 3;  // now -100 is an error; use a target list without it
  const std::vector<int64_t> y2 = {2, 0, 3, 3, 1};
  EXPECT_NEAR(nn::cross_entropy(var(z), Tensor::from_vector(y2, {5}), o).item(), naive_ce(z, y2, 3, 0.1), 1e-14);
  // (B, T, C) logits with (B, T) targets: the same as the flattened rows.
  EXPECT_NEAR(nn::cross_entropy(var(z.narrow(0, 0, 4).reshape({2, 2, 4})), Tensor::from_vector(y, {5}).narrow(0, 0, 4).reshape({2, 2})).item(),
              naive_ce(z.narrow(0, 0, 4), {2, 0, -100, 3}, -100, 0.0), 1e-14);
}

TEST(CrossEntropy, UniformLogitsGiveLogC) {
  Tensor z = Tensor::full({3, 7}, 2.5, DType::f64);
  EXPECT_NEAR(nn::cross_entropy(var(z), Tensor::from_vector(std::vector<int64_t>{0, 6, 3}, {3})).item(),
              std::log(7.0), 1e-14);
}

TEST(CrossEntropy, GradcheckLogits) {
  Tensor z = random_tensor({4, 3}, DType::f64, 13);
  Tensor y = Tensor::from_vector(std::vector<int64_t>{1, -100, 0, 2}, {4});
  nn::CrossEntropyOptions o;
  expect_gradcheck([y, o](const VV& v) { return nn::cross_entropy(v[0], y, o); }, {z});
  o.label_smoothing = 0.2;
  expect_gradcheck([y, o](const VV& v) { return nn::cross_entropy(v[0], y, o); }, {z});
}

TEST(CrossEntropy, IgnoredRowsHaveNoInfluence) {
  Tensor z = random_tensor({3, 4}, DType::f64, 14);
  Tensor y = Tensor::from_vector(std::vector<int64_t>{1, -100, 2}, {3});
  Variable vz = var(z, true);
  Variable l = nn::cross_entropy(vz, y);
  Tensor z2 = z.clone();
  for (int64_t c = 0; c < 4; ++c) z2.set({1, c}, 1e4 * (c + 1));
  EXPECT_NEAR(nn::cross_entropy(var(z2), y).item(), l.item(), 1e-14);
  l.backward();
  for (int64_t c = 0; c < 4; ++c) EXPECT_EQ(vz.grad().at({1, c}), 0.0);
  // All ignored: 0 with zero gradient, not NaN.
  Variable vz2 = var(z, true);
  Variable l2 = nn::cross_entropy(vz2, Tensor::full({3}, -100.0, DType::i64));
  EXPECT_EQ(l2.item(), 0.0);
  l2.backward();
  for (double g : raw_values(vz2.grad())) EXPECT_EQ(g, 0.0);
}

TEST(CrossEntropy, LargeLogitsStayFinite) {
  Tensor z = Tensor::from_vector(std::vector<float>{1000.f, 0.f, -1000.f, 5e4f, 5e4f, -5e4f}, {2, 3});
  Tensor y = Tensor::from_vector(std::vector<int64_t>{1, 0}, {2});
  Variable vz = var(z, true);
  Variable l = nn::cross_entropy(vz, y);
  EXPECT_NEAR(l.item(), (1000.0 + std::log(2.0)) / 2.0, 1e-3);  // row 0: 1000; row 1: log 2
  l.backward();
  for (double g : raw_values(vz.grad())) EXPECT_TRUE(std::isfinite(g));
}

TEST(Accuracy, TopKIgnoreAndTies) {
  Tensor z = Tensor::from_vector(std::vector<double>{0.1, 0.9, 0.0,   // argmax 1
                                                     0.5, 0.2, 0.3,   // argmax 0, second 2
                                                     0.4, 0.4, 0.1,   // tie between 0 and 1
                                                     0.0, 0.0, 1.0},
                                 {4, 3});
  Tensor y = Tensor::from_vector(std::vector<int64_t>{1, 2, 1, -100}, {4});
  EXPECT_NEAR(nn::accuracy(z, y), 2.0 / 3.0, 1e-15);     // row 1 wrong at top-1; the tie counts as correct
  EXPECT_NEAR(nn::accuracy(z, y, -100, 2), 1.0, 1e-15);  // row 1's target is second
  Tensor y2 = Tensor::from_vector(std::vector<int64_t>{0, 1, 2, 2}, {4});
  EXPECT_NEAR(nn::accuracy(z, y2), 1.0 / 4.0, 1e-15);
  EXPECT_EQ(nn::accuracy(z, Tensor::full({4}, -100.0, DType::i64)), 0.0);
}

TEST(CrossEntropy, BadUseThrows) {
  Tensor z = Tensor::zeros({3, 4}, DType::f64);
  expect_error([&] { nn::cross_entropy(var(z), Tensor::from_vector(std::vector<int64_t>{0, 4, 1}, {3})); },
               {"cross_entropy", "target 4", "position 1", "[0, 4)"});
  expect_error([&] { nn::cross_entropy(var(z), Tensor::from_vector(std::vector<int64_t>{0, 1}, {2})); },
               {"cross_entropy", "[3]", "[2]"});
  expect_error([&] { nn::cross_entropy(var(z), Tensor::zeros({3}, DType::f64)); }, {"cross_entropy", "int64"});
  nn::CrossEntropyOptions o;
  o.label_smoothing = 1.5;
  expect_error([&] { nn::cross_entropy(var(z), Tensor::zeros({3}, DType::i64), o); },
               {"cross_entropy", "label_smoothing", "1.5"});
  expect_error([&] { nn::accuracy(z, Tensor::zeros({3}, DType::i64), -100, 0); }, {"accuracy", "k must be"});
  expect_error([&] { nn::accuracy(z, Tensor::full({3}, -1.0, DType::i64)); }, {"accuracy", "target -1"});
}

}  // namespace
