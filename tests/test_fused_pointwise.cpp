// test_fused_pointwise.cpp — softmax / log-softmax, tanh-GELU, RoPE and nearest upsampling: forwards against
// naive double references, backwards against central finite differences, float vs double, the vectorised float
// exp against std::exp, and bad arguments.
#include <gtest/gtest.h>

#include <cmath>

#include "tensor/cpu_features.h"
#include "tensor/fused/fast_exp.h"
#include "tensor/fused/gelu_tanh.h"
#include "tensor/fused/rope.h"
#include "tensor/fused/softmax.h"
#include "tensor/fused/upsample_nearest1d.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"
#include "test_fused_util.h"

using namespace fused_test;
using namespace t2m::fused;

namespace {

TEST(FastExp, FloatExpAndTanhMatchLibm) {
  double max_rel = 0, max_tanh = 0;
  for (int i = -87000; i <= 88000; ++i) {
    const float x = (float)i * 1e-3f;
    const double want = std::exp((double)x);
    max_rel = std::max(max_rel, std::fabs(exp_approx(x) - want) / want);
  }
  for (int i = -20000; i <= 20000; ++i) {
    const float u = (float)i * 1e-3f;
    max_tanh = std::max(max_tanh, std::fabs(tanh_approx(u) - std::tanh((double)u)));
  }
  EXPECT_LT(max_rel, 4e-7);
  EXPECT_LT(max_tanh, 3e-7);
  EXPECT_EQ(exp_approx(0.0f), 1.0f);
  EXPECT_GT(exp_approx(-1000.0f), 0.0f);  // clamped, no underflow to denormals or NaN
  EXPECT_LT(exp_approx(-1000.0f), 1e-37f);
  EXPECT_TRUE(std::isfinite(exp_approx(1000.0f)));
  EXPECT_EQ(tanh_approx(100.0f), 1.0f);
  EXPECT_EQ(tanh_approx(-100.0f), -1.0f);
}

Vec ref_softmax(const Vec& x, int64_t N, int64_t C, bool log) {
  Vec y(x.size());
  for (int64_t i = 0; i < N; ++i) {
    double z = 0;
    for (int64_t c = 0; c < C; ++c) z += std::exp(x[i * C + c]);
    for (int64_t c = 0; c < C; ++c) y[i * C + c] = log ? x[i * C + c] - std::log(z) : std::exp(x[i * C + c]) / z;
  }
  return y;
}

TEST(Softmax, ForwardBackwardBothFlavours) {
  for (bool log : {false, true})
    for (auto [N, C] : {std::pair<int64_t, int64_t>{1, 1}, {3, 7}, {7, 33}, {2, 3}}) {
      SCOPED_TRACE(std::string(log ? "log_softmax" : "softmax") + " N=" + std::to_string(N) +
                   " C=" + std::to_string(C));
      Vec x = randn(N * C, 101, 3.0), R = randn(N * C, 102), y(N * C), dx(N * C, 5.0);
      auto fwd = [&]() {
        if (log)
          log_softmax_forward<double>(y.data(), x.data(), N, C);
        else
          softmax_forward<double>(y.data(), x.data(), N, C);
      };
      fwd();
      expect_close(y, ref_softmax(x, N, C, log), 1e-13, 1e-11, "forward");
      if (log)
        log_softmax_backward<double>(dx.data(), R.data(), y.data(), N, C);
      else
        softmax_backward<double>(dx.data(), R.data(), y.data(), N, C);
      expect_close(dx, numeric_grad(x, [&]() { fwd(); return dot(y, R); }), 1e-7, 1e-6, "backward");
      fwd();
      auto xf = to_float(x), Rf = to_float(R);
      std::vector<float> yf(N * C), dxf(N * C);
      if (log) {
        log_softmax_forward<float>(yf.data(), xf.data(), N, C);
        log_softmax_backward<float>(dxf.data(), Rf.data(), yf.data(), N, C);
      } else {
        softmax_forward<float>(yf.data(), xf.data(), N, C);
        softmax_backward<float>(dxf.data(), Rf.data(), yf.data(), N, C);
      }
      expect_float_matches(yf, y, 1e-5, "float forward");
      expect_float_matches(dxf, dx, 1e-5, "float backward");
    }
}

TEST(Softmax, LargeLogitsStayFinite) {
  std::vector<float> x = {1000.0f, 999.0f, -1000.0f, 1e30f}, y(4), ly(4);
  softmax_forward<float>(y.data(), x.data(), 1, 4);
  log_softmax_forward<float>(ly.data(), x.data(), 1, 4);
  EXPECT_NEAR(y[3], 1.0f, 1e-6f);
  EXPECT_EQ(ly[3], 0.0f);
  std::vector<float> x2 = {1000.0f, 999.0f}, y2(2);
  softmax_forward<float>(y2.data(), x2.data(), 1, 2);
  EXPECT_NEAR(y2[0], 1.0 / (1.0 + std::exp(-1.0)), 1e-6);
  for (float v : y) EXPECT_TRUE(std::isfinite(v));
}

double ref_gelu(double x) { return 0.5 * x * (1 + std::tanh(std::sqrt(2 / M_PI) * (x + 0.044715 * x * x * x))); }

TEST(GeluTanh, ForwardBackward) {
  for (int64_t n : {1, 3, 7, 33, 1000}) {
    Vec x = randn(n, 111, 2.0), R = randn(n, 112), y(n), dx(n);
    if (n == 1000) x[0] = 12.0, x[1] = -12.0, x[2] = 0.0;  // saturated tails and the origin
    gelu_tanh_forward<double>(y.data(), x.data(), n);
    Vec want(n);
    for (int64_t i = 0; i < n; ++i) want[i] = ref_gelu(x[i]);
    expect_close(y, want, 1e-14, 1e-12, "gelu forward");
    gelu_tanh_backward<double>(dx.data(), R.data(), x.data(), n);
    expect_close(dx, numeric_grad(x, [&]() { gelu_tanh_forward<double>(y.data(), x.data(), n); return dot(y, R); }),
                 1e-7, 1e-6, "gelu backward");
    auto xf = to_float(x), Rf = to_float(R);
    std::vector<float> yf(n), dxf(n);
    gelu_tanh_forward<float>(yf.data(), xf.data(), n);
    gelu_tanh_backward<float>(dxf.data(), Rf.data(), xf.data(), n);
    gelu_tanh_forward<double>(y.data(), x.data(), n);
    expect_float_matches(yf, y, 1e-5, "gelu float forward");
    expect_float_matches(dxf, dx, 1e-5, "gelu float backward");
  }
  // in place
  std::vector<float> v = {-1.0f, 0.5f, 2.0f};
  gelu_tanh_forward<float>(v.data(), v.data(), 3);
  EXPECT_NEAR(v[2], ref_gelu(2.0), 1e-6);
}

TEST(GeluTanh, BaselineAndAvx512BuildsGiveTheSameBits) {
  // Elementwise: the AVX-512 build only has more lanes, so every value rounds the same way (on a CPU without
  // AVX-512 both runs take the baseline build).
  const int64_t n = 100003;
  const auto x = to_float(randn(n, 113, 3.0)), R = to_float(randn(n, 114));
  std::vector<float> y[2], dx[2];
  for (int b = 0; b < 2; ++b) {
    t2m::force_baseline_isa(b == 1);
    y[b].resize(n), dx[b].resize(n);
    gelu_tanh_forward<float>(y[b].data(), x.data(), n);
    gelu_tanh_backward<float>(dx[b].data(), R.data(), x.data(), n);
  }
  t2m::force_baseline_isa(false);
  EXPECT_TRUE(bitwise_equal(y[0], y[1]));
  EXPECT_TRUE(bitwise_equal(dx[0], dx[1]));
}

TEST(Rope, ForwardMatchesDirectRotationAndBackwardIsTranspose) {
  const int64_t N = 3, T = 7, d = 8;
  const double base = 10000.0;
  Vec cs(T * d / 2), sn(T * d / 2);
  rope_table<double>(cs.data(), sn.data(), T, d, base, 2);  // positions 2..8
  Vec x = randn(N * T * d, 121), R = randn(N * T * d, 122), y(N * T * d), dx(N * T * d);
  auto fwd = [&]() { rope_forward<double>(y.data(), x.data(), cs.data(), sn.data(), N, T, d); };
  fwd();
  Vec want(N * T * d);
  for (int64_t n = 0; n < N; ++n)
    for (int64_t t = 0; t < T; ++t)
      for (int64_t i = 0; i < d / 2; ++i) {
        const double ang = (double)(t + 2) / std::pow(base, 2.0 * i / d);
        const double a = x[(n * T + t) * d + i], b = x[(n * T + t) * d + i + d / 2];
        want[(n * T + t) * d + i] = a * std::cos(ang) - b * std::sin(ang);
        want[(n * T + t) * d + i + d / 2] = a * std::sin(ang) + b * std::cos(ang);
      }
  expect_close(y, want, 1e-13, 1e-11, "rope forward");
  rope_backward<double>(dx.data(), R.data(), cs.data(), sn.data(), N, T, d);
  expect_close(dx, numeric_grad(x, [&]() { fwd(); return dot(y, R); }), 1e-7, 1e-6, "rope backward");
  // float, in place
  auto xf = to_float(x);
  std::vector<float> csf(cs.size()), snf(sn.size());
  rope_table<float>(csf.data(), snf.data(), T, d, base, 2);
  fwd();
  rope_forward<float>(xf.data(), xf.data(), csf.data(), snf.data(), N, T, d);
  expect_float_matches(xf, y, 1e-5, "rope float in place");
}

TEST(Rope, DotProductDependsOnlyOnRelativePosition) {
  const int64_t d = 16, T = 12;
  Vec cs(T * d / 2), sn(T * d / 2);
  rope_table<double>(cs.data(), sn.data(), T, d);
  const Vec q = randn(d, 131), k = randn(d, 132);
  // place q at every position and k at every position, then compare <q_m, k_n> for equal m - n
  Vec Q(T * d), K(T * d), rq(T * d), rk(T * d);
  for (int64_t t = 0; t < T; ++t)
    for (int64_t i = 0; i < d; ++i) Q[t * d + i] = q[i], K[t * d + i] = k[i];
  rope_forward<double>(rq.data(), Q.data(), cs.data(), sn.data(), 1, T, d);
  rope_forward<double>(rk.data(), K.data(), cs.data(), sn.data(), 1, T, d);
  auto score = [&](int64_t m, int64_t n) {
    double s = 0;
    for (int64_t i = 0; i < d; ++i) s += rq[m * d + i] * rk[n * d + i];
    return s;
  };
  EXPECT_NEAR(score(5, 2), score(9, 6), 1e-10);
  EXPECT_NEAR(score(0, 0), score(11, 11), 1e-10);
  EXPECT_NEAR(score(0, 0), dot(q, k), 1e-10);
  EXPECT_GT(std::fabs(score(5, 2) - score(2, 5)), 1e-6);  // but not symmetric: the offset's sign matters
}

TEST(UpsampleNearest1d, ForwardBackward) {
  const int64_t N = 3, T = 5, s = 2;
  Vec x = randn(N * T, 141), R = randn(N * T * s, 142), y(N * T * s), dx(N * T);
  upsample_nearest1d_forward<double>(y.data(), x.data(), N, T, s);
  for (int64_t n = 0; n < N; ++n)
    for (int64_t t = 0; t < T * s; ++t) EXPECT_EQ(y[n * T * s + t], x[n * T + t / s]);
  upsample_nearest1d_backward<double>(dx.data(), R.data(), N, T, s);
  auto loss = [&]() {
    upsample_nearest1d_forward<double>(y.data(), x.data(), N, T, s);
    return dot(y, R);
  };
  expect_close(dx, numeric_grad(x, loss), 1e-8, 1e-7, "upsample backward");
  Vec y3(N * T * 3);
  upsample_nearest1d_forward<double>(y3.data(), x.data(), N, T, 3);
  EXPECT_EQ(y3[3 * 3 + 2], x[3]);
}

// Row-wise and elementwise kernels do the same arithmetic per element whichever thread runs it: sizes above the
// parallel grain give bitwise the same result at 1 and 2 threads.
TEST(FusedPointwiseThreads, ParallelPathsEqualSerialBitwise) {
  const int saved = t2m::get_num_threads();
  const int64_t N = 300, C = 257, T = 40, d = 64, up = 3;
  const auto x = to_float(randn(N * C, 171, 2.0)), R = to_float(randn(N * C, 172));
  std::vector<float> cs(T * d / 2), sn(T * d / 2);
  rope_table<float>(cs.data(), sn.data(), T, d);
  auto run = [&](int threads) {
    t2m::set_num_threads(threads);
    std::vector<float> sm(N * C), dsm(N * C), ls(N * C), dls(N * C), g(N * C), dg(N * C);
    softmax_forward<float>(sm.data(), x.data(), N, C);
    softmax_backward<float>(dsm.data(), R.data(), sm.data(), N, C);
    log_softmax_forward<float>(ls.data(), x.data(), N, C);
    log_softmax_backward<float>(dls.data(), R.data(), ls.data(), N, C);
    gelu_tanh_forward<float>(g.data(), x.data(), N * C);
    gelu_tanh_backward<float>(dg.data(), R.data(), x.data(), N * C);
    const int64_t nr = (N * C) / (T * d);
    std::vector<float> r(nr * T * d), u(N * C * up), du(N * C);
    rope_forward<float>(r.data(), x.data(), cs.data(), sn.data(), nr, T, d);
    upsample_nearest1d_forward<float>(u.data(), x.data(), N, C, up);
    upsample_nearest1d_backward<float>(du.data(), u.data(), N, C, up);
    std::vector<float> all;
    for (auto* v : {&sm, &dsm, &ls, &dls, &g, &dg, &r, &u, &du}) all.insert(all.end(), v->begin(), v->end());
    return all;
  };
  const auto one = run(1), two = run(2);
  t2m::set_num_threads(saved);
  EXPECT_TRUE(bitwise_equal(one, two));
}

TEST(FusedPointwiseErrors, BadArgumentsThrow) {
  std::vector<float> b(64);
  float* p = b.data();
  EXPECT_THROW(softmax_forward<float>(p, p, 2, 0), t2m::Error);
  EXPECT_THROW(softmax_backward<float>(p, p, nullptr, 2, 3), t2m::Error);
  EXPECT_THROW(log_softmax_forward<float>(nullptr, p, 2, 3), t2m::Error);
  EXPECT_THROW(gelu_tanh_forward<float>(p, p, -1), t2m::Error);
  EXPECT_THROW(gelu_tanh_backward<float>(p, nullptr, p, 4), t2m::Error);
  EXPECT_THROW(rope_forward<float>(p, p, p, p, 1, 2, 5), t2m::Error);  // odd d
  EXPECT_THROW(rope_table<float>(p, p, 2, 4, 0.0), t2m::Error);
  EXPECT_THROW(upsample_nearest1d_forward<float>(p, p, 1, 4, 0), t2m::Error);
  try {
    rope_forward<float>(p, p, p, p, 1, 2, 5);
  } catch (const t2m::Error& e) {
    EXPECT_NE(std::string(e.what()).find("rope_forward"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("5"), std::string::npos) << e.what();
  }
}

}  // namespace
