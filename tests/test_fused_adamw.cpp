// test_fused_adamw.cpp — the fused AdamW step against a double-precision transcription of the algorithm
// (torch.optim.AdamW order: decoupled decay, moments, bias correction), the first-step closed form, the
// multi-tensor walk against the single buffer, thread-count independence and bad arguments.
#include <gtest/gtest.h>

#include <cmath>

#include "tensor/fused/adamw.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"
#include "test_fused_util.h"

using namespace fused_test;
using namespace t2m::fused;

namespace {

void ref_adamw(Vec& p, const Vec& g, Vec& m, Vec& v, const AdamWConfig& c, int64_t step) {
  for (size_t i = 0; i < p.size(); ++i) {
    p[i] *= 1.0 - (double)c.lr * c.weight_decay;
    m[i] = c.beta1 * m[i] + (1.0 - c.beta1) * g[i];
    v[i] = c.beta2 * v[i] + (1.0 - c.beta2) * g[i] * g[i];
    const double mh = m[i] / (1.0 - std::pow((double)c.beta1, (double)step));
    const double vh = v[i] / (1.0 - std::pow((double)c.beta2, (double)step));
    p[i] -= c.lr * mh / (std::sqrt(vh) + c.eps);
  }
}

TEST(AdamW, FirstStepIsSignedLearningRateAfterDecay) {
  AdamWConfig c;
  c.lr = 0.01f;
  c.weight_decay = 0.1f;
  std::vector<float> p = {1.0f, -2.0f, 0.5f}, g = {3.0f, -0.25f, 1e-3f}, m(3, 0), v(3, 0);
  adamw_step(p.data(), g.data(), m.data(), v.data(), 3, c, 1);
  // mhat = g, vhat = g^2 -> update lr * g / (|g| + eps)
  EXPECT_NEAR(p[0], 1.0 * (1 - 0.001) - 0.01, 1e-6);
  EXPECT_NEAR(p[1], -2.0 * (1 - 0.001) + 0.01, 1e-6);
  EXPECT_NEAR(p[2], 0.5 * (1 - 0.001) - 0.01 * 1e-3 / (1e-3 + 1e-8), 1e-6);
  EXPECT_NEAR(m[0], 0.1 * 3.0, 1e-7);
  EXPECT_NEAR(v[0], (1.0 - (double)0.999f) * 9.0, 1e-8);  // 1 - beta2 as rounded in float
}

TEST(AdamW, TenStepsMatchDoubleReference) {
  AdamWConfig c;
  c.lr = 3e-3f;
  c.beta1 = 0.8f;
  c.beta2 = 0.95f;
  c.eps = 1e-6f;
  c.weight_decay = 0.05f;
  const int64_t n = 37;
  Vec p = randn(n, 151), m(n, 0), v(n, 0);
  auto pf = to_float(p);
  std::vector<float> mf(n, 0), vf(n, 0);
  for (int64_t step = 1; step <= 10; ++step) {
    Vec g = randn(n, 200 + step);
    auto gf = to_float(g);
    ref_adamw(p, g, m, v, c, step);
    adamw_step(pf.data(), gf.data(), mf.data(), vf.data(), n, c, step);
  }
  expect_close(to_double(pf), p, 1e-6, 1e-5, "params after 10 steps");
  expect_close(to_double(mf), m, 1e-6, 1e-5, "first moment");
  expect_close(to_double(vf), v, 1e-7, 1e-5, "second moment");
}

TEST(AdamW, MultiTensorEqualsOneBufferAtAnyThreadCount) {
  const int saved = t2m::get_num_threads();
  const std::vector<int64_t> sizes = {1, 3, 0, 7, 40000, 33, 70001};
  int64_t total = 0;
  for (auto s : sizes) total += s;
  const auto p0 = to_float(randn(total, 161)), g = to_float(randn(total, 162));
  AdamWConfig c;
  auto run_multi = [&](int threads) {
    t2m::set_num_threads(threads);
    std::vector<float> p = p0, m(total, 0.1f), v(total, 0.2f);
    std::vector<float*> pp, mp, vp;
    std::vector<const float*> gp;
    int64_t off = 0;
    for (auto s : sizes) {
      pp.push_back(p.data() + off);
      gp.push_back(g.data() + off);
      mp.push_back(m.data() + off);
      vp.push_back(v.data() + off);
      off += s;
    }
    adamw_step(pp.data(), gp.data(), mp.data(), vp.data(), sizes.data(), (int64_t)sizes.size(), c, 3);
    p.insert(p.end(), m.begin(), m.end());
    p.insert(p.end(), v.begin(), v.end());
    return p;
  };
  t2m::set_num_threads(1);
  std::vector<float> p = p0, m(total, 0.1f), v(total, 0.2f);
  adamw_step(p.data(), g.data(), m.data(), v.data(), total, c, 3);
  p.insert(p.end(), m.begin(), m.end());
  p.insert(p.end(), v.begin(), v.end());
  const auto a1 = run_multi(1), a2 = run_multi(2), a2b = run_multi(2);
  t2m::set_num_threads(saved);
  EXPECT_TRUE(bitwise_equal(a1, p));
  EXPECT_TRUE(bitwise_equal(a2, p));
  EXPECT_TRUE(bitwise_equal(a2b, p));
  EXPECT_FALSE(bitwise_equal(std::vector<float>(p.begin(), p.begin() + total), p0));  // it did move
}

TEST(AdamW, BadArgumentsThrow) {
  std::vector<float> b(8);
  float* p = b.data();
  AdamWConfig c;
  EXPECT_THROW(adamw_step(p, p, p, p, 8, c, 0), t2m::Error);
  EXPECT_THROW(adamw_step(p, p, p, p, -1, c, 1), t2m::Error);
  c.beta1 = 1.0f;
  EXPECT_THROW(adamw_step(p, p, p, p, 8, c, 1), t2m::Error);
  c = AdamWConfig{};
  c.lr = -1.0f;
  EXPECT_THROW(adamw_step(p, p, p, p, 8, c, 1), t2m::Error);
  c = AdamWConfig{};
  EXPECT_THROW(adamw_step(p, nullptr, p, p, 8, c, 1), t2m::Error);
  try {
    adamw_step(p, p, p, p, 8, c, 0);
  } catch (const t2m::Error& e) {
    EXPECT_NE(std::string(e.what()).find("adamw_step"), std::string::npos) << e.what();
  }
}

}  // namespace
