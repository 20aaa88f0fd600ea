// test_fused_norm.cpp — LayerNorm, RMSNorm and GroupNorm fused kernels: forward against naive double references,
// backward against central finite differences of sum(out * R), accumulation of parameter grads, float vs double,
// determinism at 2 threads and bad arguments.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "tensor/fused/group_norm.h"
#include "tensor/fused/layer_norm.h"
#include "tensor/fused/rms_norm.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"
#include "test_fused_util.h"

using namespace fused_test;
using namespace t2m::fused;

namespace {

// Naive reference: normalise each block of `n` elements (rows of C, or GroupNorm blocks), then affine by channel.
Vec ref_layer_norm(const Vec& x, const Vec* w, const Vec* b, int64_t N, int64_t C, double eps, bool rms) {
  Vec y(x.size());
  for (int64_t i = 0; i < N; ++i) {
    double m = 0, v = 0;
    for (int64_t c = 0; c < C; ++c) m += x[i * C + c];
    m = rms ? 0.0 : m / C;
    for (int64_t c = 0; c < C; ++c) v += (x[i * C + c] - m) * (x[i * C + c] - m);
    v /= C;
    for (int64_t c = 0; c < C; ++c) {
      double n = (x[i * C + c] - m) / std::sqrt(v + eps);
      y[i * C + c] = n * (w ? (*w)[c] : 1.0) + (b ? (*b)[c] : 0.0);
    }
  }
  return y;
}

Vec ref_group_norm(const Vec& x, const Vec* w, const Vec* b, int64_t B, int64_t C, int64_t T, int64_t G,
                   double eps) {
  Vec y(x.size());
  const int64_t Cg = C / G;
  for (int64_t bb = 0; bb < B; ++bb)
    for (int64_t g = 0; g < G; ++g) {
      double m = 0, v = 0;
      for (int64_t c = g * Cg; c < (g + 1) * Cg; ++c)
        for (int64_t t = 0; t < T; ++t) m += x[(bb * C + c) * T + t];
      m /= Cg * T;
      for (int64_t c = g * Cg; c < (g + 1) * Cg; ++c)
        for (int64_t t = 0; t < T; ++t) v += std::pow(x[(bb * C + c) * T + t] - m, 2);
      v /= Cg * T;
      for (int64_t c = g * Cg; c < (g + 1) * Cg; ++c)
        for (int64_t t = 0; t < T; ++t) {
          const int64_t i = (bb * C + c) * T + t;
          y[i] = (x[i] - m) / std::sqrt(v + eps) * (w ? (*w)[c] : 1.0) + (b ? (*b)[c] : 0.0);
        }
    }
  return y;
}

struct NormCase {
  int64_t N, C;
  bool affine;
};

class LayerNormTest : public ::testing::TestWithParam<NormCase> {};

TEST_P(LayerNormTest, ForwardBackwardMatchReferenceAndFiniteDifferences) {
  const auto [N, C, affine] = GetParam();
  const double eps = 1e-5;
  Vec x = randn(N * C, 1), w = randn(C, 2, 0.5), b = randn(C, 3), R = randn(N * C, 4);
  for (auto& wi : w) wi += 1.0;
  Vec y(N * C), mean(N), rstd(N);
  auto fwd = [&]() {
    layer_norm_forward<double>(y.data(), mean.data(), rstd.data(), x.data(), affine ? w.data() : nullptr,
                               affine ? b.data() : nullptr, N, C, eps);
  };
  fwd();
  expect_close(y, ref_layer_norm(x, affine ? &w : nullptr, affine ? &b : nullptr, N, C, eps, false), 1e-12, 1e-10,
               "layer_norm y");
  Vec dx(N * C), dw(C, 0.25), db(C, -0.5);  // grads accumulate onto these
  layer_norm_backward<double>(dx.data(), affine ? dw.data() : nullptr, affine ? db.data() : nullptr, R.data(),
                              x.data(), affine ? w.data() : nullptr, mean.data(), rstd.data(), N, C);
  auto loss = [&]() {
    fwd();
    return dot(y, R);
  };
  expect_close(dx, numeric_grad(x, loss), 1e-6, 1e-5, "layer_norm dinp");
  if (affine) {
    Vec gw = numeric_grad(w, loss), gb = numeric_grad(b, loss);
    for (int64_t c = 0; c < C; ++c) {
      gw[c] += 0.25;
      gb[c] -= 0.5;
    }
    expect_close(dw, gw, 1e-6, 1e-5, "layer_norm dweight (accumulated)");
    expect_close(db, gb, 1e-6, 1e-5, "layer_norm dbias (accumulated)");
  }
  // float agrees with double
  auto xf = to_float(x), wf = to_float(w), bf = to_float(b), Rf = to_float(R);
  std::vector<float> yf(N * C), mf(N), rf(N), dxf(N * C), dwf(C, 0.25f), dbf(C, -0.5f);
  layer_norm_forward<float>(yf.data(), mf.data(), rf.data(), xf.data(), affine ? wf.data() : nullptr,
                            affine ? bf.data() : nullptr, N, C, 1e-5f);
  layer_norm_backward<float>(dxf.data(), affine ? dwf.data() : nullptr, affine ? dbf.data() : nullptr, Rf.data(),
                             xf.data(), affine ? wf.data() : nullptr, mf.data(), rf.data(), N, C);
  fwd();
  expect_float_matches(yf, y, 1e-5, "layer_norm float y");
  expect_float_matches(dxf, dx, 1e-5, "layer_norm float dinp");
  if (affine) expect_float_matches(dwf, dw, 1e-5, "layer_norm float dweight");
}

INSTANTIATE_TEST_SUITE_P(Sizes, LayerNormTest,
                         ::testing::Values(NormCase{1, 1, true}, NormCase{3, 7, true}, NormCase{7, 33, true},
                                           NormCase{3, 7, false}, NormCase{1, 3, true}));

TEST(LayerNorm, BiasOnlyAffine) {
  const int64_t N = 3, C = 5;
  Vec x = randn(N * C, 11), b = randn(C, 12), y(N * C), mean(N), rstd(N);
  layer_norm_forward<double>(y.data(), mean.data(), rstd.data(), x.data(), nullptr, b.data(), N, C, 1e-5);
  expect_close(y, ref_layer_norm(x, nullptr, &b, N, C, 1e-5, false), 1e-12, 1e-10, "bias-only y");
}

TEST(RmsNorm, ForwardBackwardMatchReferenceAndFiniteDifferences) {
  for (auto [N, C, affine] : {NormCase{1, 1, true}, NormCase{3, 7, true}, NormCase{7, 33, false},
                              NormCase{5, 33, true}}) {
    SCOPED_TRACE("N=" + std::to_string(N) + " C=" + std::to_string(C));
    const double eps = 1e-6;
    Vec x = randn(N * C, 5), w = randn(C, 6, 0.5), R = randn(N * C, 7);
    Vec y(N * C), rstd(N);
    auto fwd = [&]() {
      rms_norm_forward<double>(y.data(), rstd.data(), x.data(), affine ? w.data() : nullptr, N, C, eps);
    };
    fwd();
    expect_close(y, ref_layer_norm(x, affine ? &w : nullptr, nullptr, N, C, eps, true), 1e-12, 1e-10, "rms y");
    Vec dx(N * C), dw(C, 1.0);
    rms_norm_backward<double>(dx.data(), affine ? dw.data() : nullptr, R.data(), x.data(),
                              affine ? w.data() : nullptr, rstd.data(), N, C);
    auto loss = [&]() {
      fwd();
      return dot(y, R);
    };
    expect_close(dx, numeric_grad(x, loss), 1e-6, 1e-5, "rms dinp");
    if (affine) {
      Vec gw = numeric_grad(w, loss);
      for (auto& g : gw) g += 1.0;
      expect_close(dw, gw, 1e-6, 1e-5, "rms dweight");
    }
    auto xf = to_float(x), wf = to_float(w), Rf = to_float(R);
    std::vector<float> yf(N * C), rf(N), dxf(N * C);
    rms_norm_forward<float>(yf.data(), rf.data(), xf.data(), affine ? wf.data() : nullptr, N, C, 1e-6f);
    rms_norm_backward<float>(dxf.data(), nullptr, Rf.data(), xf.data(), affine ? wf.data() : nullptr, rf.data(), N,
                             C);
    fwd();
    expect_float_matches(yf, y, 1e-5, "rms float y");
    expect_float_matches(dxf, dx, 1e-5, "rms float dinp");
  }
}

struct GnCase {
  int64_t B, C, T, G;
  bool affine;
};

class GroupNormTest : public ::testing::TestWithParam<GnCase> {};

TEST_P(GroupNormTest, ForwardBackwardMatchReferenceAndFiniteDifferences) {
  const auto [B, C, T, G, affine] = GetParam();
  const double eps = 1e-5;
  const int64_t n = B * C * T;
  Vec x = randn(n, 21), w = randn(C, 22, 0.5), b = randn(C, 23), R = randn(n, 24);
  Vec y(n), mean(B * G), rstd(B * G);
  const Vec* wp = affine ? &w : nullptr;
  const Vec* bp = affine ? &b : nullptr;
  auto fwd = [&]() {
    group_norm_forward<double>(y.data(), mean.data(), rstd.data(), x.data(), affine ? w.data() : nullptr,
                               affine ? b.data() : nullptr, B, C, T, G, eps);
  };
  fwd();
  expect_close(y, ref_group_norm(x, wp, bp, B, C, T, G, eps), 1e-12, 1e-10, "group_norm y");
  Vec dx(n), dw(C, 0.5), db(C, 0.5);
  group_norm_backward<double>(dx.data(), affine ? dw.data() : nullptr, affine ? db.data() : nullptr, R.data(),
                              x.data(), affine ? w.data() : nullptr, mean.data(), rstd.data(), B, C, T, G);
  auto loss = [&]() {
    fwd();
    return dot(y, R);
  };
  expect_close(dx, numeric_grad(x, loss), 1e-6, 1e-5, "group_norm dinp");
  if (affine) {
    Vec gw = numeric_grad(w, loss), gb = numeric_grad(b, loss);
    for (int64_t c = 0; c < C; ++c) {
      gw[c] += 0.5;
      gb[c] += 0.5;
    }
    expect_close(dw, gw, 1e-6, 1e-5, "group_norm dweight");
    expect_close(db, gb, 1e-6, 1e-5, "group_norm dbias");
  }
  auto xf = to_float(x), wf = to_float(w), bf = to_float(b), Rf = to_float(R);
  std::vector<float> yf(n), mf(B * G), rf(B * G), dxf(n), dwf(C, 0.5f), dbf(C, 0.5f);
  group_norm_forward<float>(yf.data(), mf.data(), rf.data(), xf.data(), affine ? wf.data() : nullptr,
                            affine ? bf.data() : nullptr, B, C, T, G, 1e-5f);
  group_norm_backward<float>(dxf.data(), affine ? dwf.data() : nullptr, affine ? dbf.data() : nullptr, Rf.data(),
                             xf.data(), affine ? wf.data() : nullptr, mf.data(), rf.data(), B, C, T, G);
  fwd();
  expect_float_matches(yf, y, 1e-5, "group_norm float y");
  expect_float_matches(dxf, dx, 1e-5, "group_norm float dinp");
  if (affine) expect_float_matches(dwf, dw, 1e-5, "group_norm float dweight");
}

INSTANTIATE_TEST_SUITE_P(Sizes, GroupNormTest,
                         ::testing::Values(GnCase{1, 1, 1, 1, true}, GnCase{3, 6, 7, 3, true},
                                           GnCase{2, 4, 5, 1, true}, GnCase{2, 7, 3, 7, true},
                                           GnCase{3, 6, 7, 2, false}, GnCase{1, 9, 33, 3, true}));

// Parameter-grad reductions are per-thread partials reduced in a fixed order: repeated runs at 2 threads are
// bitwise equal, and 1 thread agrees to rounding.
TEST(FusedNormDeterminism, RepeatedRunsAtTwoThreadsAreBitwiseEqual) {
  const int saved = t2m::get_num_threads();
  const int64_t B = 8, C = 64, T = 65, G = 8, N = B * T;  // > kParallelGrain elements
  const auto x = to_float(randn(B * C * T, 31)), R = to_float(randn(B * C * T, 32));
  const auto w = to_float(randn(C, 33)), b = to_float(randn(C, 34));
  auto run = [&](int threads) {
    t2m::set_num_threads(threads);
    std::vector<float> y(B * C * T), mean(B * G), rstd(B * G), dx(B * C * T), dw(C, 0), db(C, 0);
    group_norm_forward<float>(y.data(), mean.data(), rstd.data(), x.data(), w.data(), b.data(), B, C, T, G, 1e-5f);
    group_norm_backward<float>(dx.data(), dw.data(), db.data(), R.data(), x.data(), w.data(), mean.data(),
                               rstd.data(), B, C, T, G);
    // LayerNorm over rows of C after viewing x as (N, C)
    std::vector<float> y2(N * C), m2(N), r2(N), dx2(N * C), dw2(C, 0), db2(C, 0);
    layer_norm_forward<float>(y2.data(), m2.data(), r2.data(), x.data(), w.data(), b.data(), N, C, 1e-5f);
    layer_norm_backward<float>(dx2.data(), dw2.data(), db2.data(), R.data(), x.data(), w.data(), m2.data(),
                               r2.data(), N, C);
    std::vector<float> all;
    for (auto* v : {&y, &dx, &dw, &db, &y2, &dx2, &dw2, &db2}) all.insert(all.end(), v->begin(), v->end());
    return all;
  };
  const auto a = run(2), a2 = run(2), one = run(1);
  t2m::set_num_threads(saved);
  EXPECT_TRUE(bitwise_equal(a, a2));
  expect_float_matches(a, to_double(one), 1e-5, "1 vs 2 threads");
}

// The forward takes its rows' statistics four at a time (the last row repeated when fewer are left): a row's mean,
// rstd and output bits do not depend on which rows it is grouped with, i.e. on N, its position or the threads.
TEST(LayerNorm, ForwardRowBitsDoNotDependOnGrouping) {
  const int saved = t2m::get_num_threads();
  for (int64_t C : {int64_t(1024), int64_t(37), int64_t(9)}) {
    const int64_t N = std::max<int64_t>(7, 40000 / C + 3);  // past kParallelGrain: both threads get rows
    const auto x = to_float(randn(N * C, 51)), w = to_float(randn(C, 52)), b = to_float(randn(C, 53));
    for (int threads : {1, 2}) {
      t2m::set_num_threads(threads);
      std::vector<float> y(N * C), mean(N), rstd(N);
      layer_norm_forward<float>(y.data(), mean.data(), rstd.data(), x.data(), w.data(), b.data(), N, C, 1e-5f);
      for (int64_t i = 0; i < N; i += 1 + i / 3) {  // row i alone, and as the second of a pair
        for (int64_t first : {i, std::max<int64_t>(i - 1, 0)}) {
          const int64_t n = i - first + 1;
          std::vector<float> y1(n * C), m1(n), r1(n);
          layer_norm_forward<float>(y1.data(), m1.data(), r1.data(), x.data() + first * C, w.data(), b.data(), n, C,
                                    1e-5f);
          const std::vector<float> row(y.begin() + i * C, y.begin() + (i + 1) * C),
              row1(y1.end() - C, y1.end());
          EXPECT_TRUE(bitwise_equal(row, row1)) << "C " << C << " row " << i << " threads " << threads;
          EXPECT_TRUE(bitwise_equal({mean[i], rstd[i]}, {m1[n - 1], r1[n - 1]})) << "C " << C << " row " << i;
        }
      }
    }
  }
  t2m::set_num_threads(saved);
}

// GroupNorm's (sample, group) blocks go through the same four-at-a-time statistics: a sample's bits do not depend
// on the batch around it (blocks of 4 straddle samples when G = 3) or on the threads.
TEST(GroupNorm, ForwardSampleBitsDoNotDependOnGrouping) {
  const int saved = t2m::get_num_threads();
  const int64_t B = 11, C = 12, T = 300, G = 3, n = C * T;  // past kParallelGrain
  const auto x = to_float(randn(B * n, 61)), w = to_float(randn(C, 62)), b = to_float(randn(C, 63));
  for (int threads : {1, 2}) {
    t2m::set_num_threads(threads);
    std::vector<float> y(B * n), mean(B * G), rstd(B * G);
    group_norm_forward<float>(y.data(), mean.data(), rstd.data(), x.data(), w.data(), b.data(), B, C, T, G, 1e-5f,
                              true);
    for (int64_t i = 0; i < B; ++i) {
      std::vector<float> y1(n), m1(G), r1(G);
      group_norm_forward<float>(y1.data(), m1.data(), r1.data(), x.data() + i * n, w.data(), b.data(), 1, C, T, G,
                                1e-5f, true);
      EXPECT_TRUE(bitwise_equal(std::vector<float>(y.begin() + i * n, y.begin() + (i + 1) * n), y1))
          << "sample " << i << " threads " << threads;
      EXPECT_TRUE(bitwise_equal(std::vector<float>(mean.begin() + i * G, mean.begin() + (i + 1) * G), m1));
      EXPECT_TRUE(bitwise_equal(std::vector<float>(rstd.begin() + i * G, rstd.begin() + (i + 1) * G), r1));
    }
  }
  t2m::set_num_threads(saved);
}

// layer_norm_backward with tanh_out (the backward of tanh(LayerNorm(x))) gives the bits of forming
// g (1 - y^2) in a pass of its own and running the plain backward on it, with and without affine, 1 and 2 threads.
TEST(LayerNorm, BackwardThroughTanhMatchesTwoPasses) {
  const int saved = t2m::get_num_threads();
  const int64_t N = 300, C = 130;  // > kParallelGrain elements
  const auto x = to_float(randn(N * C, 41)), g = to_float(randn(N * C, 42));
  const auto w = to_float(randn(C, 43)), b = to_float(randn(C, 44));
  for (bool affine : {true, false})
    for (int threads : {1, 2}) {
      t2m::set_num_threads(threads);
      const float* wp = affine ? w.data() : nullptr;
      std::vector<float> y(N * C), mean(N), rstd(N);
      layer_norm_forward<float>(y.data(), mean.data(), rstd.data(), x.data(), wp, affine ? b.data() : nullptr, N, C,
                                1e-5f);
      for (auto& v : y) v = std::tanh(v);
      std::vector<float> dpre(N * C), dx1(N * C), dw1(C, 0), db1(C, 0), dx2(N * C), dw2(C, 0), db2(C, 0);
      for (int64_t i = 0; i < N * C; ++i) dpre[i] = g[i] * (1.0f - y[i] * y[i]);
      layer_norm_backward<float>(dx1.data(), affine ? dw1.data() : nullptr, affine ? db1.data() : nullptr,
                                 dpre.data(), x.data(), wp, mean.data(), rstd.data(), N, C);
      layer_norm_backward<float>(dx2.data(), affine ? dw2.data() : nullptr, affine ? db2.data() : nullptr, g.data(),
                                 x.data(), wp, mean.data(), rstd.data(), N, C, y.data());
      EXPECT_TRUE(bitwise_equal(dx1, dx2)) << "affine " << affine << " threads " << threads;
      EXPECT_TRUE(bitwise_equal(dw1, dw2));
      EXPECT_TRUE(bitwise_equal(db1, db2));
      EXPECT_TRUE(std::any_of(dx2.begin(), dx2.end(), [](float v) { return v != 0.0f; }));
    }
  t2m::set_num_threads(saved);
}

TEST(FusedNormErrors, BadArgumentsThrow) {
  std::vector<float> x(12), y(12), m(4), r(4);
  EXPECT_THROW(group_norm_forward<float>(y.data(), m.data(), r.data(), x.data(), nullptr, nullptr, 1, 6, 2, 4, 1e-5f),
               t2m::Error);  // 6 % 4 != 0
  EXPECT_THROW(group_norm_forward<float>(y.data(), m.data(), r.data(), x.data(), nullptr, nullptr, 1, 6, 0, 3, 1e-5f),
               t2m::Error);
  EXPECT_THROW(layer_norm_forward<float>(y.data(), m.data(), r.data(), x.data(), nullptr, nullptr, -1, 3, 1e-5f),
               t2m::Error);
  EXPECT_THROW(layer_norm_forward<float>(y.data(), m.data(), r.data(), x.data(), nullptr, nullptr, 4, 0, 1e-5f),
               t2m::Error);
  EXPECT_THROW(layer_norm_forward<float>(y.data(), nullptr, r.data(), x.data(), nullptr, nullptr, 4, 3, 1e-5f),
               t2m::Error);
  EXPECT_THROW(layer_norm_forward<float>(y.data(), m.data(), r.data(), x.data(), nullptr, nullptr, 4, 3, -1.0f),
               t2m::Error);
  EXPECT_THROW(rms_norm_backward<float>(nullptr, nullptr, x.data(), x.data(), nullptr, r.data(), 4, 3), t2m::Error);
  try {
    group_norm_backward<float>(x.data(), nullptr, nullptr, x.data(), x.data(), nullptr, m.data(), r.data(), 1, 6, 2,
                               4);
    FAIL() << "expected t2m::Error";
  } catch (const t2m::Error& e) {
    EXPECT_NE(std::string(e.what()).find("group_norm_backward"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("C=6"), std::string::npos) << e.what();
  }
  // N == 0 is a no-op, not an error
  EXPECT_NO_THROW(layer_norm_forward<float>(nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, 0, 3, 1e-5f));
}

}  // namespace
