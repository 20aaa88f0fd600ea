// test_loss_contrastive.cpp — InfoNCE and the Eq 11–12 reduction (nn/loss_contrastive.h) and the frame-token
// contrastive loss of Eq 7–12 (nn/loss_frame_token.h): values against a naive loop implementation written from
// the paper's equations, float64 gradchecks w.r.t. motion, text and the logit scale, padding masks, false-negative
// exclusion, large-logit stability, limits (aligned -> ~0, uniform -> log B) and error messages.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "autograd/autograd.h"
#include "nn/loss_contrastive.h"
#include "nn/loss_frame_token.h"
#include "nn/loss_token_pool.h"
#include "tensor/ops.h"
#include "tensor/parallel.h"
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
Tensor scalar64(double v) { return Tensor::scalar(v, DType::f64); }

void expect_gradcheck(const ag::GradcheckFn& f, const std::vector<Tensor>& in) {
  ag::GradcheckResult r = ag::gradcheck(f, in);
  EXPECT_TRUE(r.ok) << r.message;
}

using Mat = std::vector<std::vector<double>>;

// Naive Eq 11–12 on a logits matrix; ids (may be empty) exclude off-diagonal pairs sharing an id.
double naive_symmetric(const Mat& L, const std::vector<int64_t>& ids) {
  const size_t B = L.size();
  auto skip = [&](size_t i, size_t j) { return !ids.empty() && i != j && ids[i] == ids[j]; };
  double m2t = 0.0, t2m = 0.0;
  for (size_t i = 0; i < B; ++i) {
    double sr = 0.0, sc = 0.0;
    for (size_t j = 0; j < B; ++j) {
      if (!skip(i, j)) sr += std::exp(L[i][j]);
      if (!skip(j, i)) sc += std::exp(L[j][i]);
    }
    m2t += std::log(sr) - L[i][i];
    t2m += std::log(sc) - L[i][i];
  }
  return 0.5 * (m2t + t2m) / (double)B;
}

// Naive Eq 7–10: R[i][j] from motion (Bm, Tm, D), text (Bt, K, D) and 0/1 validity lists.
Mat naive_R(const Tensor& m, const std::vector<int>& mv, const Tensor& y, const std::vector<int>& yv, double lt,
            double lf) {
  const int64_t Bm = m.size(0), Tm = m.size(1), Bt = y.size(0), K = y.size(1), D = m.size(2);
  auto unit = [D](const Tensor& x, int64_t a, int64_t b) {
    std::vector<double> v(D);
    double n = 0.0;
    for (int64_t d = 0; d < D; ++d) n += x.at({a, b, d}) * x.at({a, b, d});
    n = std::max(std::sqrt(n), 1e-12);
    for (int64_t d = 0; d < D; ++d) v[d] = x.at({a, b, d}) / n;
    return v;
  };
  Mat R(Bm, std::vector<double>(Bt, 0.0));
  for (int64_t i = 0; i < Bm; ++i)
    for (int64_t j = 0; j < Bt; ++j) {
      std::vector<double> F(Tm, 0.0);
      double kj = 0.0;
      for (int64_t k = 0; k < K; ++k) kj += yv[j * K + k];
      for (int64_t t = 0; t < Tm; ++t) {
        const std::vector<double> a = unit(m, i, t);
        double s = 0.0;
        for (int64_t k = 0; k < K; ++k) {
          if (!yv[j * K + k]) continue;
          const std::vector<double> b = unit(y, j, k);
          double dot = 0.0;
          for (int64_t d = 0; d < D; ++d) dot += a[d] * b[d];
          s += std::exp(dot / lt);
        }
        F[t] = lt * std::log(s / kj);  // Eq 8
      }
      double z = 0.0, r = 0.0;
      for (int64_t t = 0; t < Tm; ++t)
        if (mv[i * Tm + t]) z += std::exp(F[t] / lf);
      for (int64_t t = 0; t < Tm; ++t)
        if (mv[i * Tm + t]) r += std::exp(F[t] / lf) / z * F[t];  // Eq 9–10
      R[i][j] = r;
    }
  return R;
}

Tensor mask_tensor(const std::vector<int>& v, const Shape& s) {
  std::vector<int64_t> w(v.begin(), v.end());
  return Tensor::from_vector(w, s);
}

// ---- logit scale -------------------------------------------------------------------------------------------------

TEST(LogitScale, ClampedLikeClipAndClampInPlace) {
  EXPECT_NEAR(nn::logit_scale_gamma(var(scalar64(std::log(20.0)))).item(), 20.0, 1e-12);
  EXPECT_NEAR(nn::logit_scale_gamma(var(scalar64(10.0))).item(), 100.0, 1e-10);
  EXPECT_NEAR(nn::logit_scale_gamma(var(scalar64(-3.0))).item(), 1.0, 1e-15);
  Variable a = Variable::parameter(Tensor::from_vector(std::vector<double>{7.0}, {1}));
  nn::clamp_logit_scale_(a);
  EXPECT_NEAR(a.item(), std::log(100.0), 1e-15);
  EXPECT_NEAR(nn::kInitLogitScale, std::log(1.0 / 0.07), 1e-15);
  expect_error([] { nn::logit_scale_gamma(var(Tensor::zeros({2}, DType::f64))); }, {"logit_scale_gamma", "[2]"});
}

// ---- symmetric contrastive / InfoNCE -----------------------------------------------------------------------------

TEST(InfoNce, UniformIsLogBAndAlignedIsZero) {
  const int64_t B = 5;
  Tensor same = Tensor::ones({B, 3}, DType::f64);  // every embedding identical: all logits equal
  nn::ContrastiveLoss u = nn::info_nce(var(same), var(same), var(scalar64(std::log(10.0))));
  EXPECT_NEAR(u.loss.item(), std::log((double)B), 1e-13);
  EXPECT_NEAR(u.motion_to_text.item(), std::log((double)B), 1e-13);
  // Orthonormal pairs with γ = 100: loss = log(1 + (B - 1) e^-100) ~ 0.
  Tensor eye = Tensor::zeros({B, B}, DType::f64);
  for (int64_t i = 0; i < B; ++i) eye.set({i, i}, 1.0 + i);  // unnormalised on purpose
  nn::ContrastiveLoss a = nn::info_nce(var(eye), var(eye), var(scalar64(nn::kMaxLogitScale)));
  EXPECT_LT(a.loss.item(), 1e-40);
  EXPECT_GE(a.loss.item(), 0.0);
}

TEST(InfoNce, MatchesNaiveWithFalseNegatives) {
  Tensor m = random_tensor({4, 3}, DType::f64, 1), y = random_tensor({4, 3}, DType::f64, 2);
  const double alpha = 1.3;
  Mat L(4, std::vector<double>(4));
  for (int64_t i = 0; i < 4; ++i)
    for (int64_t j = 0; j < 4; ++j) {
      double dot = 0.0, nm = 0.0, ny = 0.0;
      for (int64_t d = 0; d < 3; ++d) {
        dot += m.at({i, d}) * y.at({j, d});
        nm += m.at({i, d}) * m.at({i, d});
        ny += y.at({j, d}) * y.at({j, d});
      }
      L[i][j] = std::exp(alpha) * dot / std::sqrt(nm * ny);
    }
  EXPECT_NEAR(nn::info_nce(var(m), var(y), var(scalar64(alpha))).loss.item(), naive_symmetric(L, {}), 1e-13);
  const std::vector<int64_t> ids = {7, 3, 7, 5};  // pairs 0 and 2 share a caption
  Tensor tid = Tensor::from_vector(ids, {4});
  nn::ContrastiveLoss r = nn::info_nce(var(m), var(y), var(scalar64(alpha)), tid);
  EXPECT_NEAR(r.loss.item(), naive_symmetric(L, ids), 1e-13);
  EXPECT_GT(std::abs(r.loss.item() - naive_symmetric(L, {})), 1e-3);  // the exclusion changes the value
}

TEST(InfoNce, GradcheckEmbeddingsAndLogitScale) {
  Tensor m = random_tensor({3, 4}, DType::f64, 3), y = random_tensor({3, 4}, DType::f64, 4);
  Tensor tid = Tensor::from_vector(std::vector<int64_t>{0, 1, 0}, {3});
  expect_gradcheck([](const VV& v) { return nn::info_nce(v[0], v[1], v[2]).loss; }, {m, y, scalar64(1.1)});
  expect_gradcheck([tid](const VV& v) { return nn::info_nce(v[0], v[1], v[2], tid).text_to_motion; },
                   {m, y, scalar64(2.0)});
  expect_gradcheck([](const VV& v) { return nn::info_nce(v[0], v[1], v[2], Tensor(), false).loss; },
                   {m, y, scalar64(0.4)});
}

TEST(SymmetricContrastive, GradcheckLogitsWithExclusion) {
  Tensor L = random_tensor({4, 4}, DType::f64, 6, -3, 3);
  Tensor tid = Tensor::from_vector(std::vector<int64_t>{1, 2, 1, 1}, {4});
  expect_gradcheck([tid](const VV& v) { return nn::symmetric_contrastive(v[0], tid).loss; }, {L});
  expect_gradcheck([](const VV& v) { return nn::symmetric_contrastive(v[0]).motion_to_text; }, {L});
}

TEST(L2Normalize, UnitRowsZeroRowAndGradcheck) {
  Tensor x = random_tensor({3, 4}, DType::f64, 7);
  for (int64_t d = 0; d < 4; ++d) x.set({1, d}, 0.0);
  Tensor y = nn::l2_normalize(var(x)).data();
  for (int64_t r = 0; r < 3; ++r) {
    double n = 0.0;
    for (int64_t d = 0; d < 4; ++d) n += y.at({r, d}) * y.at({r, d});
    EXPECT_NEAR(n, r == 1 ? 0.0 : 1.0, 1e-14);
  }
  expect_gradcheck([](const VV& v) { return nn::l2_normalize(v[0]); }, {random_tensor({2, 3}, DType::f64, 8)});
}

TEST(SymmetricContrastive, HugeLogitsStayFinite) {
  Tensor L = random_tensor({4, 4}, DType::f32, 5, -1e4, 1e4);
  Variable vl = var(L, true);
  nn::ContrastiveLoss r = nn::symmetric_contrastive(vl);
  EXPECT_TRUE(std::isfinite(r.loss.item()));
  r.loss.backward();
  for (double g : raw_values(vl.grad())) EXPECT_TRUE(std::isfinite(g));
}

TEST(SymmetricContrastive, BadUseThrows) {
  expect_error([] { nn::symmetric_contrastive(var(Tensor::zeros({3, 4}))); }, {"symmetric_contrastive", "[3, 4]"});
  expect_error([] { nn::symmetric_contrastive(var(Tensor::zeros({3, 3})), Tensor::zeros({3})); },
               {"symmetric_contrastive", "text_ids", "int64"});
  expect_error([] { nn::info_nce(var(Tensor::zeros({3, 4})), var(Tensor::zeros({3, 5})), var(Tensor::zeros({}))); },
               {"info_nce", "[3, 4]", "[3, 5]"});
}

// ---- fused token pooling (Eq 8) ----------------------------------------------------------------------------------

TEST(MaskedLogMeanExp, MatchesNaiveAndGradchecks) {
  Tensor x = random_tensor({2, 3, 4}, DType::f64, 60, -3, 3);
  const std::vector<int> v = {1, 0, 1, 1, 0, 0, 0, 1, 1, 1, 1, 1};
  Tensor valid = mask_tensor(v, {3, 4});
  Tensor out = nn::masked_log_mean_exp(var(x), valid).data();
  ASSERT_EQ(out.shape(), (Shape{2, 3}));
  for (int64_t n = 0; n < 2; ++n)
    for (int64_t j = 0; j < 3; ++j) {
      double s = 0.0, kj = 0.0;
      for (int64_t k = 0; k < 4; ++k)
        if (v[j * 4 + k]) s += std::exp(x.at({n, j, k})), kj += 1.0;
      EXPECT_NEAR(out.at({n, j}), std::log(s / kj), 1e-14);
    }
  expect_gradcheck([valid](const VV& a) { return nn::masked_log_mean_exp(a[0], valid); }, {x});
  // A transposed (non-contiguous) input gives the same values.
  Tensor xt = x.transpose(0, 1).contiguous().transpose(0, 1);
  EXPECT_EQ(max_abs_diff(nn::masked_log_mean_exp(var(xt), valid).data(), out), 0.0);
}

TEST(MaskedLogMeanExp, HugeValuesAndPaddingGarbage) {
  Tensor x = Tensor::from_vector(std::vector<float>{3e4f, 3e4f + 1.f, -1e30f, 1e30f}, {1, 1, 4});
  Tensor valid = Tensor::from_vector(std::vector<int64_t>{1, 1, 1, 0}, {1, 4});
  Variable vx = var(x, true);
  Variable out = nn::masked_log_mean_exp(vx, valid);
  EXPECT_NEAR(out.item(), 3e4 + 1.0 + std::log((1.0 + std::exp(-1.0)) / 3.0), 1e-2);
  out.backward();
  EXPECT_EQ(vx.grad().at({0, 0, 3}), 0.0);  // padded: no gradient even with a huge value
  EXPECT_NEAR(vx.grad().at({0, 0, 1}), 1.0 / (1.0 + std::exp(-1.0)), 1e-6);
  expect_error([] { nn::masked_log_mean_exp(var(Tensor::zeros({2, 3})), Tensor::ones({3})); },
               {"masked_log_mean_exp", "(N, J, K)", "[2, 3]"});
  expect_error([] { nn::masked_log_mean_exp(var(Tensor::zeros({2, 3, 4})), Tensor::ones({3, 5})); },
               {"masked_log_mean_exp", "[3, 4]", "[3, 5]"});
  expect_error([] { nn::masked_log_mean_exp(var(Tensor::zeros({2, 1, 2})), Tensor::zeros({1, 2})); },
               {"masked_log_mean_exp", "row 0", "no valid"});
}

// ---- frame-token (Eq 7–12) ---------------------------------------------------------------------------------------

struct FtCase {
  Tensor m, y;
  std::vector<int> mv, yv;
};

// Bm = Bt = 3, Tm = 3, K = 4, D = 3; clip 1 has 2 frames, caption 0 has 2 tokens, caption 2 has 3.
FtCase small_case(uint32_t seed) {
  FtCase c;
  c.m = random_tensor({3, 3, 3}, DType::f64, seed);
  c.y = random_tensor({3, 4, 3}, DType::f64, seed + 100);
  c.mv = {1, 1, 1, 1, 1, 0, 1, 1, 1};
  c.yv = {1, 1, 0, 0, 1, 1, 1, 1, 1, 1, 1, 0};
  return c;
}

TEST(FrameToken, SimilarityMatchesNaiveEquations) {
  FtCase c = small_case(10);
  for (double lt : {0.1, 0.5})
    for (double lf : {0.05, 1.0}) {
      nn::FrameTokenOptions o;
      o.lambda_tok = lt;
      o.lambda_frm = lf;
      Tensor R = nn::frame_token_similarity(var(c.m), mask_tensor(c.mv, {3, 3}), var(c.y), mask_tensor(c.yv, {3, 4}), o)
                     .data();
      const Mat ref = naive_R(c.m, c.mv, c.y, c.yv, lt, lf);
      for (int64_t i = 0; i < 3; ++i)
        for (int64_t j = 0; j < 3; ++j) EXPECT_NEAR(R.at({i, j}), ref[i][j], 1e-13) << lt << " " << lf;
    }
  // Different motion and text batch sizes are fine for the similarity (retrieval).
  Tensor R = nn::frame_token_similarity(var(c.m), Tensor(), var(c.y.narrow(0, 0, 2)), Tensor()).data();
  EXPECT_EQ(R.shape(), (Shape{3, 2}));
}

TEST(FrameToken, LossMatchesNaiveAndLimits) {
  FtCase c = small_case(20);
  const double alpha = 2.0;
  nn::FrameTokenOptions o;
  nn::ContrastiveLoss r = nn::frame_token_contrastive_loss(var(c.m), mask_tensor(c.mv, {3, 3}), var(c.y),
                                                           mask_tensor(c.yv, {3, 4}), var(scalar64(alpha)), o);
  Mat L = naive_R(c.m, c.mv, c.y, c.yv, o.lambda_tok, o.lambda_frm);
  for (auto& row : L)
    for (double& v : row) v *= std::exp(alpha);
  EXPECT_NEAR(r.loss.item(), naive_symmetric(L, {}), 1e-13);
  // One token and one frame: R is the cosine of the two vectors.
  Tensor m1 = random_tensor({2, 1, 3}, DType::f64, 21), y1 = random_tensor({2, 1, 3}, DType::f64, 22);
  Tensor R = nn::frame_token_similarity(var(m1), Tensor(), var(y1), Tensor()).data();
  double dot = 0, nm = 0, ny = 0;
  for (int64_t d = 0; d < 3; ++d) {
    dot += m1.at({0, 0, d}) * y1.at({1, 0, d});
    nm += m1.at({0, 0, d}) * m1.at({0, 0, d});
    ny += y1.at({1, 0, d}) * y1.at({1, 0, d});
  }
  EXPECT_NEAR(R.at({0, 1}), dot / std::sqrt(nm * ny), 1e-14);
  // Clips made of their caption's tokens, orthogonal across pairs, γ = 100 -> loss ~ 0.
  Tensor me = Tensor::zeros({3, 2, 3}, DType::f64), ye = Tensor::zeros({3, 2, 3}, DType::f64);
  for (int64_t i = 0; i < 3; ++i)
    for (int64_t t = 0; t < 2; ++t) {
      me.set({i, t, i}, 1.0);
      ye.set({i, t, i}, 2.0);
    }
  EXPECT_LT(nn::frame_token_contrastive_loss(var(me), Tensor(), var(ye), Tensor(), var(scalar64(10.0))).loss.item(),
            1e-30);
  // Identical features everywhere: uniform logits -> log B.
  Tensor ones = Tensor::ones({3, 2, 3}, DType::f64);
  EXPECT_NEAR(nn::frame_token_contrastive_loss(var(ones), Tensor(), var(ones), Tensor(), var(scalar64(3.0))).loss.item(),
              std::log(3.0), 1e-13);
}

TEST(FrameToken, GradcheckMotionTextAndLogitScale) {
  FtCase c = small_case(30);
  Tensor mm = mask_tensor(c.mv, {3, 3}), ym = mask_tensor(c.yv, {3, 4});
  nn::FrameTokenOptions o;
  o.lambda_tok = 0.3;
  o.lambda_frm = 0.2;
  expect_gradcheck([=](const VV& v) { return nn::frame_token_contrastive_loss(v[0], mm, v[1], ym, v[2], o).loss; },
                   {c.m, c.y, scalar64(1.5)});
  o.text_ids = Tensor::from_vector(std::vector<int64_t>{4, 9, 4}, {3});
  expect_gradcheck([=](const VV& v) { return nn::frame_token_contrastive_loss(v[0], mm, v[1], ym, v[2], o).loss; },
                   {c.m, c.y, scalar64(0.7)});
  expect_gradcheck([=](const VV& v) { return nn::frame_token_similarity(v[0], mm, v[1], ym, o); }, {c.m, c.y});
}

TEST(FrameToken, PaddingIsIgnored) {
  FtCase c = small_case(40);
  Tensor mm = mask_tensor(c.mv, {3, 3}), ym = mask_tensor(c.yv, {3, 4});
  Tensor m2 = c.m.clone(), y2 = c.y.clone();
  for (int64_t d = 0; d < 3; ++d) {
    m2.set({1, 2, d}, 1e5 * (d + 1));  // the padded frame of clip 1
    y2.set({0, 2, d}, -3e4);           // padded tokens of caption 0
    y2.set({0, 3, d}, 0.0);            // an all-zero padded token (norm 0)
  }
  Variable vm = var(m2, true), vy = var(y2, true), va = var(scalar64(2.5), true);
  nn::ContrastiveLoss r = nn::frame_token_contrastive_loss(vm, mm, vy, ym, va);
  nn::ContrastiveLoss ref = nn::frame_token_contrastive_loss(var(c.m), mm, var(c.y), ym, var(scalar64(2.5)));
  EXPECT_NEAR(r.loss.item(), ref.loss.item(), 1e-14);
  r.loss.backward();
  for (int64_t d = 0; d < 3; ++d) {
    EXPECT_EQ(vm.grad().at({1, 2, d}), 0.0);
    EXPECT_EQ(vy.grad().at({0, 2, d}), 0.0);
    EXPECT_EQ(vy.grad().at({0, 3, d}), 0.0);
  }
  EXPECT_NE(va.grad().item(), 0.0);
  for (double g : raw_values(vm.grad())) EXPECT_TRUE(std::isfinite(g));
}

TEST(FrameToken, SharpTemperaturesAndMaxScaleStayFinite) {
  Tensor m = random_tensor({4, 5, 8}, DType::f32, 50), y = random_tensor({4, 6, 8}, DType::f32, 51);
  nn::FrameTokenOptions o;
  o.lambda_tok = 1e-3;  // exp(1/λ) would overflow float32 without the max subtraction
  o.lambda_frm = 1e-3;
  Variable vm = var(m, true), vy = var(y, true), va = var(Tensor::scalar(4.6f), true);
  nn::ContrastiveLoss r = nn::frame_token_contrastive_loss(vm, Tensor(), vy, Tensor(), va, o);
  EXPECT_TRUE(std::isfinite(r.loss.item()));
  r.loss.backward();
  for (const Tensor& g : {vm.grad(), vy.grad(), va.grad()})
    for (double v : raw_values(g)) EXPECT_TRUE(std::isfinite(v));
  // float32 agrees with float64 on the default temperatures.
  nn::ContrastiveLoss r32 = nn::frame_token_contrastive_loss(var(m), Tensor(), var(y), Tensor(), var(Tensor::scalar(2.f)));
  nn::ContrastiveLoss r64 = nn::frame_token_contrastive_loss(var(m.to(DType::f64)), Tensor(), var(y.to(DType::f64)),
                                                             Tensor(), var(scalar64(2.0)));
  EXPECT_NEAR(r32.loss.item(), r64.loss.item(), 1e-5);
}

TEST(FrameToken, SameResultForOneAndTwoThreads) {
  // Large enough for the fused pooling (N·J·K = 32768) and the GEMM to take their threaded paths.
  Generator g(5);
  Tensor m = rand_normal({8, 8, 16}, g), y = rand_normal({8, 64, 16}, g);
  auto run = [&](int nt) {
    set_num_threads(nt);
    Variable vm = var(m, true), vy = var(y, true);
    nn::ContrastiveLoss r = nn::frame_token_contrastive_loss(vm, Tensor(), vy, Tensor(), var(Tensor::scalar(2.f)));
    r.loss.backward();
    return std::vector<Tensor>{r.loss.data(), vm.grad(), vy.grad()};
  };
  const int prev = get_num_threads();
  const std::vector<Tensor> a = run(1), b = run(2);
  set_num_threads(prev);
  for (size_t i = 0; i < a.size(); ++i) EXPECT_EQ(max_abs_diff(a[i], b[i]), 0.0) << "output " << i;
}

TEST(FrameToken, BadUseThrows) {
  Tensor m = Tensor::zeros({2, 3, 4}, DType::f64), y = Tensor::zeros({2, 5, 4}, DType::f64);
  Variable a = var(scalar64(1.0));
  expect_error([&] { nn::frame_token_similarity(var(m), Tensor(), var(Tensor::zeros({2, 5, 3}, DType::f64)), Tensor()); },
               {"frame_token", "[2, 3, 4]", "[2, 5, 3]"});
  expect_error([&] { nn::frame_token_similarity(var(m), Tensor::ones({2, 4}), var(y), Tensor()); },
               {"frame_token", "motion_mask", "[2, 3]", "[2, 4]"});
  Tensor ym = Tensor::ones({2, 5});
  ym.set({1, 0}, 0.0), ym.set({1, 1}, 0.0), ym.set({1, 2}, 0.0), ym.set({1, 3}, 0.0), ym.set({1, 4}, 0.0);
  expect_error([&] { nn::frame_token_similarity(var(m), Tensor(), var(y), ym); },
               {"frame_token", "text_mask", "row 1", "no valid"});
  nn::FrameTokenOptions o;
  o.lambda_frm = 0.0;
  expect_error([&] { nn::frame_token_similarity(var(m), Tensor(), var(y), Tensor(), o); }, {"frame_token", "lambda"});
  expect_error([&] { nn::frame_token_contrastive_loss(var(m), Tensor(), var(y.narrow(0, 0, 1)), Tensor(), a); },
               {"frame_token", "Bm == Bt"});
  expect_error([&] { nn::frame_token_contrastive_loss(var(m), Tensor(), var(y), Tensor(), var(Tensor::zeros({2}, DType::f64))); },
               {"frame_token", "[2]"});
  expect_error([&] { nn::frame_token_similarity(var(m), Tensor(), var(y.to(DType::f32)), Tensor()); },
               {"frame_token", "dtype"});
}

}  // namespace
