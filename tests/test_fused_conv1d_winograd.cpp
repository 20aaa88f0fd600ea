// test_fused_conv1d_winograd.cpp — Winograd F(2, 3) and F(4, 3) conv1d (tensor/fused/conv1d_winograd.h) against a
// direct double-precision convolution and its gradient loops written here, backward against central finite
// differences in double, float against double, the im2col path on VBB-sized shapes, chunking, the automatic
// tile choice and bad configurations.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <tuple>

#include "tensor/fused/conv1d.h"
#include "tensor/fused/conv1d_winograd.h"
#include "tensor/tensor.h"
#include "test_fused_util.h"

using namespace fused_test;
using namespace t2m::fused;

namespace {

Conv1dShape shape(int64_t B, int64_t Cin, int64_t Cout, int64_t T, int64_t dil, int64_t pad, bool causal) {
  Conv1dShape s;
  s.B = B;
  s.Cin = Cin;
  s.Cout = Cout;
  s.T = T;
  s.K = 3;
  s.dilation = dil;
  s.pad = pad;
  s.causal = causal;
  return s;
}

// Input frame that output frame `to`, tap k reads: -1 for a zero pad, else the clamped (replicated) frame.
int64_t src_frame(const Conv1dShape& s, int64_t to, int64_t k) {
  const int64_t t = to + k * s.dilation - s.pad_left();
  if (t < 0) return s.causal ? 0 : -1;
  return t < s.T ? t : -1;
}

struct Ref {
  Vec y, dx, dw, db;
};

// Direct definition and its gradients for upstream gradient R: y = conv(x, w) + b; dx, dw, db of <y, R>.
Ref reference(const Conv1dShape& s, const Vec& x, const Vec& w, const Vec& b, const Vec& R) {
  const int64_t To = s.out_len();
  Ref r{Vec(s.B * s.Cout * To, 0.0), Vec(x.size(), 0.0), Vec(w.size(), 0.0), Vec(b.size(), 0.0)};
  for (int64_t n = 0; n < s.B; ++n)
    for (int64_t co = 0; co < s.Cout; ++co)
      for (int64_t to = 0; to < To; ++to) {
        const size_t yi = (n * s.Cout + co) * To + to;
        double acc = b[co];
        const double g = R[yi];
        r.db[co] += g;
        for (int64_t ci = 0; ci < s.Cin; ++ci)
          for (int64_t k = 0; k < 3; ++k) {
            const int64_t t = src_frame(s, to, k);
            if (t < 0) continue;
            const size_t xi = (n * s.Cin + ci) * s.T + t, wi = (co * s.Cin + ci) * 3 + k;
            acc += w[wi] * x[xi];
            r.dw[wi] += g * x[xi];
            r.dx[xi] += g * w[wi];
          }
        r.y[yi] = acc;
      }
  return r;
}

// (B, Cin, Cout, T, dilation, pad, causal) x tile m.
using Param = std::tuple<Conv1dShape, int>;
class WinogradTest : public ::testing::TestWithParam<Param> {};

TEST_P(WinogradTest, MatchesDirectConvolutionGradientsAndFiniteDifferences) {
  const auto [s, m] = GetParam();
  const int64_t To = s.out_len();
  Vec x = randn(s.B * s.Cin * s.T, 11), w = randn(s.Cout * s.Cin * 3, 12), b = randn(s.Cout, 13);
  const Vec R = randn(s.B * s.Cout * To, 14);
  const Ref ref = reference(s, x, w, b, R);
  Vec y(ref.y.size());
  conv1d_winograd_forward<double>(y.data(), x.data(), w.data(), b.data(), s, m);
  expect_close(y, ref.y, 1e-11, 1e-10, "winograd y");
  Vec dx(x.size(), 7.0), dw(w.size(), 0.5), db(b.size(), -1.0);
  conv1d_winograd_backward<double>(dx.data(), dw.data(), db.data(), R.data(), x.data(), w.data(), s, m);
  Vec rdw = ref.dw, rdb = ref.db;
  for (auto& g : rdw) g += 0.5;
  for (auto& g : rdb) g -= 1.0;
  expect_close(dx, ref.dx, 1e-11, 1e-10, "winograd dinp (written)");
  expect_close(dw, rdw, 1e-11, 1e-10, "winograd dweight (accumulated)");
  expect_close(db, rdb, 1e-11, 1e-10, "winograd dbias (accumulated)");

  // central finite differences of <y, R> in double, on the Winograd forward itself
  if (x.size() + w.size() <= 600) {
    auto loss = [&]() {
      conv1d_winograd_forward<double>(y.data(), x.data(), w.data(), b.data(), s, m);
      return dot(y, R);
    };
    Vec gw = numeric_grad(w, loss);
    for (auto& g : gw) g += 0.5;
    expect_close(dx, numeric_grad(x, loss), 1e-6, 1e-6, "winograd dinp vs finite differences");
    expect_close(dw, gw, 1e-6, 1e-6, "winograd dweight vs finite differences");
  }

  // float against the double reference
  auto xf = to_float(x), wf = to_float(w), bf = to_float(b), Rf = to_float(R);
  std::vector<float> yf(y.size()), dxf(x.size()), dwf(w.size(), 0.5f), dbf(b.size(), -1.0f);
  conv1d_winograd_forward<float>(yf.data(), xf.data(), wf.data(), bf.data(), s, m);
  conv1d_winograd_backward<float>(dxf.data(), dwf.data(), dbf.data(), Rf.data(), xf.data(), wf.data(), s, m);
  const double tol = m == 2 ? 1e-5 : 3e-5;
  expect_float_matches(yf, ref.y, tol, "winograd float y");
  expect_float_matches(dxf, ref.dx, tol, "winograd float dinp");
  expect_float_matches(dwf, rdw, tol, "winograd float dweight");
  expect_float_matches(dbf, rdb, tol, "winograd float dbias");
}

INSTANTIATE_TEST_SUITE_P(
    Shapes, WinogradTest,
    ::testing::Combine(::testing::Values(shape(1, 1, 1, 1, 1, 0, true),     // one frame, causal
                                         shape(2, 3, 4, 7, 1, 0, true),     // causal, T not a tile multiple
                                         shape(2, 3, 2, 8, 1, 1, false),    // "same" zero padding
                                         shape(1, 2, 3, 33, 3, 0, true),    // dilation 3
                                         shape(1, 2, 3, 33, 9, 0, true),    // dilation 9, pad longer than T/2
                                         shape(1, 2, 2, 3, 2, 0, true),     // T shorter than the causal pad
                                         shape(2, 3, 3, 19, 2, 0, false),   // no padding (To = T - 4)
                                         shape(3, 16, 8, 16, 3, 0, true)),  // channels > the 8 of auto dispatch
                       ::testing::Values(2, 4)));

// VBB-sized shapes (width 256 at T 64/32/16/8, dilations 1/3/9): Winograd against the im2col path in float and
// both against the double reference; several chunks of samples (B 90 at width 256 and T 64 is 3 chunks).
TEST(Conv1dWinograd, VbbShapesMatchIm2colAndDoubleReference) {
  for (const Conv1dShape& s0 : {shape(90, 256, 256, 64, 1, 0, true), shape(3, 256, 256, 32, 9, 0, true),
                                shape(4, 256, 256, 16, 3, 0, true), shape(4, 256, 96, 8, 1, 0, true)}) {
    const int64_t To = s0.out_len();
    const Vec x = randn(s0.B * s0.Cin * s0.T, 21), w = randn(s0.Cout * s0.Cin * 3, 22, 0.06), b = randn(s0.Cout, 23);
    const Vec R = randn(s0.B * s0.Cout * To, 24);
    const auto xf = to_float(x), wf = to_float(w), bf = to_float(b), Rf = to_float(R);
    std::vector<std::vector<float>> res;
    for (Conv1dAlgo algo : {Conv1dAlgo::im2col, Conv1dAlgo::winograd}) {
      Conv1dShape s = s0;
      s.algo = algo;
      std::vector<float> y(R.size()), dx(x.size()), dw(w.size(), 0.0f), db(b.size(), 0.0f);
      conv1d_forward<float>(y.data(), xf.data(), wf.data(), bf.data(), s);
      conv1d_backward<float>(dx.data(), dw.data(), db.data(), Rf.data(), xf.data(), wf.data(), s);
      std::vector<float> all;
      for (auto* v : {&y, &dx, &dw, &db}) all.insert(all.end(), v->begin(), v->end());
      res.push_back(all);
    }
    if (s0.B <= 4) {  // the direct double loops are slow at B 90
      const Ref ref = reference(s0, x, w, b, R);
      Vec all;
      for (const Vec* v : {&ref.y, &ref.dx, &ref.dw, &ref.db}) all.insert(all.end(), v->begin(), v->end());
      expect_float_matches(res[1], all, 3e-5, "winograd vs double reference");
      expect_float_matches(res[0], all, 3e-5, "im2col vs double reference");
    }
    expect_float_matches(res[1], to_double(res[0]), 3e-5, "winograd vs im2col");
  }
}

TEST(Conv1dWinograd, AutomaticTileChoice) {
  EXPECT_EQ(conv1d_winograd_tile(shape(32, 256, 256, 64, 1, 1, false)), 4);  // 1.5 vs 3 multiply-adds per frame
  EXPECT_EQ(conv1d_winograd_tile(shape(32, 256, 256, 64, 1, 0, true)), 2);   // causal: F(2,3) only
  Conv1dShape loose = shape(32, 256, 256, 64, 1, 0, true);
  loose.exact_causal = false;
  EXPECT_EQ(conv1d_winograd_tile(loose), 4);  // causal up to rounding: F(4,3) allowed
  EXPECT_EQ(conv1d_winograd_tile(shape(32, 256, 256, 8, 9, 0, true)), 0);    // every tile drops most outputs
  EXPECT_EQ(conv1d_winograd_tile(shape(32, 256, 256, 16, 9, 9, false)), 2);  // F(4,3) would waste more
  EXPECT_EQ(conv1d_winograd_tile(shape(32, 4, 256, 64, 1, 0, true)), 0);     // too few channels to pay
  Conv1dShape k4 = shape(32, 256, 256, 64, 1, 0, true);
  k4.K = 4;
  EXPECT_EQ(conv1d_winograd_tile(k4), 0);
  k4.K = 3;
  k4.stride = 2;
  EXPECT_EQ(conv1d_winograd_tile(k4), 0);
}

// A causal conv through the automatic path (F(2,3) here) is exactly causal: changing input frame t leaves every
// output frame before t bitwise unchanged, for each dilation of the VBB.
TEST(Conv1dWinograd, AutomaticPathIsExactlyCausal) {
  for (int64_t dil : {1, 3, 9}) {
    const Conv1dShape s = shape(2, 16, 16, 40, dil, 0, true);
    ASSERT_NE(conv1d_winograd_tile(s), 0) << "dilation " << dil;
    auto x = to_float(randn(s.B * s.Cin * s.T, 31)), w = to_float(randn(s.Cout * s.Cin * 3, 32));
    std::vector<float> y0(s.B * s.Cout * s.T), y1(y0.size());
    conv1d_forward<float>(y0.data(), x.data(), w.data(), nullptr, s);
    for (int64_t t : {1, 7, 20, 39}) {
      auto xt = x;
      for (int64_t n = 0; n < s.B; ++n)
        for (int64_t ci = 0; ci < s.Cin; ++ci) xt[(n * s.Cin + ci) * s.T + t] += 1.0f + (float)ci;
      conv1d_forward<float>(y1.data(), xt.data(), w.data(), nullptr, s);
      for (int64_t n = 0; n < s.B; ++n)
        for (int64_t co = 0; co < s.Cout; ++co)
          for (int64_t u = 0; u < t; ++u) {
            const size_t i = (n * s.Cout + co) * s.T + u;
            ASSERT_EQ(y0[i], y1[i]) << "dilation " << dil << ": output frame " << u << " saw input frame " << t;
          }
    }
  }
}

// exact_causal = false (F(4,3) on a causal conv): a change at input frame t moves earlier outputs by rounding only
// (the cancelled terms of the tile), far less than it moves output frame t itself.
TEST(Conv1dWinograd, LooseCausalLeaksOnlyRounding) {
  for (int64_t dil : {1, 3}) {
    Conv1dShape s = shape(2, 16, 16, 40, dil, 0, true);
    s.exact_causal = false;
    ASSERT_EQ(conv1d_winograd_tile(s), 4) << "dilation " << dil;
    auto x = to_float(randn(s.B * s.Cin * s.T, 33)), w = to_float(randn(s.Cout * s.Cin * 3, 34));
    std::vector<float> y0(s.B * s.Cout * s.T), y1(y0.size());
    conv1d_forward<float>(y0.data(), x.data(), w.data(), nullptr, s);
    auto xt = x;
    const int64_t t = 21;
    for (int64_t n = 0; n < s.B; ++n)
      for (int64_t ci = 0; ci < s.Cin; ++ci) xt[(n * s.Cin + ci) * s.T + t] += 1.0f;
    conv1d_forward<float>(y1.data(), xt.data(), w.data(), nullptr, s);
    double early = 0, direct = 0;
    for (int64_t n = 0; n < s.B; ++n)
      for (int64_t co = 0; co < s.Cout; ++co) {
        const size_t i = (n * s.Cout + co) * s.T;
        for (int64_t u = 0; u < t; ++u) early = std::max(early, (double)std::fabs(y0[i + u] - y1[i + u]));
        direct = std::max(direct, (double)std::fabs(y0[i + t] - y1[i + t]));
      }
    EXPECT_GT(direct, 0.5) << "dilation " << dil;
    EXPECT_LT(early, 1e-4) << "dilation " << dil;
  }
}

TEST(Conv1dWinograd, BadConfigurationsThrow) {
  std::vector<float> buf(4096);
  float* p = buf.data();
  Conv1dShape s = shape(1, 2, 2, 16, 1, 0, true);
  EXPECT_THROW(conv1d_winograd_forward<float>(p, p, p, nullptr, s, 3), t2m::Error);  // tile 3
  EXPECT_THROW(conv1d_winograd_forward<float>(p, p, nullptr, nullptr, s, 2), t2m::Error);
  s.K = 4;
  EXPECT_THROW(conv1d_winograd_forward<float>(p, p, p, nullptr, s, 2), t2m::Error);
  s.algo = Conv1dAlgo::winograd;  // forcing Winograd on a k4 conv through conv1d_forward throws as well
  EXPECT_THROW(conv1d_forward<float>(p, p, p, nullptr, s), t2m::Error);
  s.K = 3;
  s.stride = 2;
  EXPECT_THROW(conv1d_winograd_backward<float>(p, p, p, p, p, p, s, 2), t2m::Error);
}

}  // namespace
