// test_fused_conv1d.cpp — conv1d (im2col + gemm) against a direct double-precision convolution written here,
// backward against central finite differences, for stride/dilation/zero-padding/causal-replicate variants,
// float vs double, determinism at 2 threads and bad configurations.
#include <gtest/gtest.h>

#include "tensor/fused/conv1d.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"
#include "test_fused_util.h"

using namespace fused_test;
using namespace t2m::fused;

namespace {

// Direct definition: out[b,co,to] = bias[co] + sum_{ci,k} w[co,ci,k] * xpad[b,ci,to*stride + k*dil - padL], where
// xpad is zero outside [0, T) for zero padding and x[.., 0] left of 0 for causal padding.
Vec ref_conv1d(const Vec& x, const Vec& w, const Vec* bias, const Conv1dShape& s) {
  const int64_t To = s.out_len(), padL = s.pad_left();  // causal: causal_left, or (K-1)*dil when it is -1
  Vec y(s.B * s.Cout * To, 0.0);
  for (int64_t b = 0; b < s.B; ++b)
    for (int64_t co = 0; co < s.Cout; ++co)
      for (int64_t to = 0; to < To; ++to) {
        double acc = bias ? (*bias)[co] : 0.0;
        for (int64_t ci = 0; ci < s.Cin; ++ci)
          for (int64_t k = 0; k < s.K; ++k) {
            int64_t t = to * s.stride + k * s.dilation - padL;
            double xv;
            if (t < 0)
              xv = s.causal ? x[(b * s.Cin + ci) * s.T] : 0.0;
            else if (t >= s.T)
              xv = 0.0;
            else
              xv = x[(b * s.Cin + ci) * s.T + t];
            acc += w[(co * s.Cin + ci) * s.K + k] * xv;
          }
        y[(b * s.Cout + co) * To + to] = acc;
      }
  return y;
}

Conv1dShape shape(int64_t B, int64_t Cin, int64_t Cout, int64_t T, int64_t K, int64_t stride, int64_t dil,
                  int64_t pad, bool causal) {
  Conv1dShape s;
  s.B = B;
  s.Cin = Cin;
  s.Cout = Cout;
  s.T = T;
  s.K = K;
  s.stride = stride;
  s.dilation = dil;
  s.pad = pad;
  s.causal = causal;
  return s;
}

Conv1dShape causal_left(Conv1dShape s, int64_t left) {
  s.causal_left = left;
  return s;
}

class Conv1dTest : public ::testing::TestWithParam<Conv1dShape> {};

TEST_P(Conv1dTest, ForwardBackwardMatchDirectConvolutionAndFiniteDifferences) {
  const Conv1dShape s = GetParam();
  const int64_t To = s.out_len();
  Vec x = randn(s.B * s.Cin * s.T, 41), w = randn(s.Cout * s.Cin * s.K, 42), b = randn(s.Cout, 43);
  const Vec R = randn(s.B * s.Cout * To, 44);
  Vec y(s.B * s.Cout * To);
  auto fwd = [&]() { conv1d_forward<double>(y.data(), x.data(), w.data(), b.data(), s); };
  fwd();
  expect_close(y, ref_conv1d(x, w, &b, s), 1e-12, 1e-10, "conv1d y");
  Vec dx(x.size(), 123.0), dw(w.size(), 0.5), db(b.size(), -1.0);
  conv1d_backward<double>(dx.data(), dw.data(), db.data(), R.data(), x.data(), w.data(), s);
  auto loss = [&]() {
    fwd();
    return dot(y, R);
  };
  expect_close(dx, numeric_grad(x, loss), 1e-6, 1e-6, "conv1d dinp (written, not accumulated)");
  Vec gw = numeric_grad(w, loss), gb = numeric_grad(b, loss);
  for (auto& g : gw) g += 0.5;
  for (auto& g : gb) g -= 1.0;
  expect_close(dw, gw, 1e-6, 1e-6, "conv1d dweight (accumulated)");
  expect_close(db, gb, 1e-6, 1e-6, "conv1d dbias (accumulated)");

  // float kernels agree with double
  auto xf = to_float(x), wf = to_float(w), bf = to_float(b), Rf = to_float(R);
  std::vector<float> yf(y.size()), dxf(x.size()), dwf(w.size(), 0.5f), dbf(b.size(), -1.0f);
  conv1d_forward<float>(yf.data(), xf.data(), wf.data(), bf.data(), s);
  conv1d_backward<float>(dxf.data(), dwf.data(), dbf.data(), Rf.data(), xf.data(), wf.data(), s);
  fwd();
  expect_float_matches(yf, y, 1e-5, "conv1d float y");
  expect_float_matches(dxf, dx, 1e-5, "conv1d float dinp");
  expect_float_matches(dwf, dw, 1e-5, "conv1d float dweight");
  expect_float_matches(dbf, db, 1e-5, "conv1d float dbias");
}

INSTANTIATE_TEST_SUITE_P(
    Variants, Conv1dTest,
    ::testing::Values(shape(1, 1, 1, 1, 1, 1, 1, 0, false),   // scalar
                      shape(2, 3, 4, 7, 3, 1, 1, 1, false),   // same padding
                      shape(2, 3, 2, 7, 3, 2, 1, 1, false),   // stride 2
                      shape(1, 2, 3, 33, 3, 1, 3, 0, false),  // dilation 3, no padding
                      shape(2, 3, 3, 7, 3, 3, 2, 2, false),   // stride 3, dilation 2, pad 2
                      shape(2, 3, 4, 7, 3, 1, 1, 0, true),    // causal k3
                      shape(1, 2, 3, 33, 3, 1, 9, 0, true),   // causal dilation 9 (pad longer than T/2)
                      shape(2, 3, 2, 8, 4, 2, 1, 0, true),    // causal k4 stride 2, 3 frames replicated
                      causal_left(shape(2, 3, 2, 8, 4, 2, 1, 0, true), 2),  // VBB downsampling: k4 s2, 2 frames
                      causal_left(shape(2, 3, 2, 9, 3, 1, 2, 0, true), 1),  // fewer frames than (K-1)*dil
                      causal_left(shape(1, 2, 2, 6, 3, 2, 1, 0, true), 5),  // more frames than (K-1)*dil
                      causal_left(shape(2, 2, 3, 5, 2, 2, 1, 0, true), 0),  // none: a plain valid conv
                      shape(3, 4, 5, 7, 1, 1, 1, 0, false),   // k1 (pointwise)
                      shape(1, 2, 2, 3, 3, 1, 2, 0, true)));  // T=3 shorter than the causal pad (4)

TEST(Conv1d, NoBiasAndSkippedGradients) {
  const Conv1dShape s = shape(2, 3, 2, 5, 3, 1, 1, 1, false);
  Vec x = randn(30, 51), w = randn(18, 52), R = randn(20, 53);
  Vec y(20);
  conv1d_forward<double>(y.data(), x.data(), w.data(), nullptr, s);
  expect_close(y, ref_conv1d(x, w, nullptr, s), 1e-12, 1e-10, "no-bias y");
  // only dweight requested
  Vec dw(18, 0.0), dw_full(18, 0.0), dx(30), db(2, 0.0);
  conv1d_backward<double>(nullptr, dw.data(), nullptr, R.data(), x.data(), w.data(), s);
  conv1d_backward<double>(dx.data(), dw_full.data(), db.data(), R.data(), x.data(), w.data(), s);
  expect_close(dw, dw_full, 1e-14, 0, "dweight alone == dweight with everything");
  // calling twice accumulates twice
  conv1d_backward<double>(nullptr, dw.data(), nullptr, R.data(), x.data(), w.data(), s);
  Vec two = dw_full;
  for (auto& g : two) g *= 2;
  expect_close(dw, two, 1e-12, 1e-12, "dweight accumulates");
}

// Shapes whose column matrix exceeds the kernel's 4 MB chunk: the batch is processed in chunks of samples (here
// 2, 2, 1; 1, 1, 1; and 2, 1 for the pointwise one, which reads inp and writes dinp in place, 2000-frame segments
// not a multiple of the GEMM's panel width); values and all three gradients against direct double loops.
TEST(Conv1d, BatchChunksMatchDirectConvolution) {
  for (const Conv1dShape& s : {shape(5, 128, 2, 2000, 2, 1, 1, 0, true), shape(3, 64, 2, 8200, 4, 2, 1, 0, true),
                               shape(3, 256, 2, 2000, 1, 1, 1, 0, false)}) {
    const int64_t To = s.out_len(), padL = (s.K - 1) * s.dilation + 0;
    Vec x = randn(s.B * s.Cin * s.T, 71), w = randn(s.Cout * s.Cin * s.K, 72), b = randn(s.Cout, 73);
    const Vec R = randn(s.B * s.Cout * To, 74);
    // The kernel's causal padding is (K-1)*dilation (stride > 1 included); the reference follows that rule.
    Vec y(s.B * s.Cout * To), dx(x.size()), dw(w.size(), 0.0), db(b.size(), 0.0);
    conv1d_forward<double>(y.data(), x.data(), w.data(), b.data(), s);
    conv1d_backward<double>(dx.data(), dw.data(), db.data(), R.data(), x.data(), w.data(), s);
    expect_close(y, ref_conv1d(x, w, &b, s), 1e-12, 1e-10, "chunked y");
    Vec rdx(x.size(), 0.0), rdw(w.size(), 0.0), rdb(b.size(), 0.0);
    for (int64_t bb = 0; bb < s.B; ++bb)
      for (int64_t co = 0; co < s.Cout; ++co)
        for (int64_t to = 0; to < To; ++to) {
          const double g = R[(bb * s.Cout + co) * To + to];
          rdb[co] += g;
          for (int64_t ci = 0; ci < s.Cin; ++ci)
            for (int64_t k = 0; k < s.K; ++k) {
              int64_t t = to * s.stride + k * s.dilation - padL;
              t = t < 0 ? 0 : t;  // replicate frame 0
              rdw[(co * s.Cin + ci) * s.K + k] += g * x[(bb * s.Cin + ci) * s.T + t];
              rdx[(bb * s.Cin + ci) * s.T + t] += g * w[(co * s.Cin + ci) * s.K + k];
            }
        }
    expect_close(dx, rdx, 1e-12, 1e-10, "chunked dinp");
    expect_close(dw, rdw, 1e-12, 1e-10, "chunked dweight");
    expect_close(db, rdb, 1e-12, 1e-10, "chunked dbias");
    auto xf = to_float(x), wf = to_float(w), bf = to_float(b), Rf = to_float(R);
    std::vector<float> yf(y.size()), dxf(x.size()), dwf(w.size(), 0.0f), dbf(b.size(), 0.0f);
    conv1d_forward<float>(yf.data(), xf.data(), wf.data(), bf.data(), s);
    conv1d_backward<float>(dxf.data(), dwf.data(), dbf.data(), Rf.data(), xf.data(), wf.data(), s);
    expect_float_matches(yf, y, 1e-5, "chunked float y");
    expect_float_matches(dxf, dx, 1e-5, "chunked float dinp");
    expect_float_matches(dwf, dw, 1e-5, "chunked float dweight");
  }
}

TEST(Conv1d, OutputLengthFormula) {
  EXPECT_EQ(shape(1, 1, 1, 64, 3, 1, 1, 0, true).out_len(), 64);   // causal keeps the length
  EXPECT_EQ(shape(1, 1, 1, 64, 4, 2, 1, 0, true).out_len(), 32);   // floor((64+3-3-1)/2)+1
  EXPECT_EQ(shape(1, 1, 1, 7, 3, 2, 1, 1, false).out_len(), 4);    // floor((7+2-2-1)/2)+1
  EXPECT_EQ(shape(1, 1, 1, 33, 3, 1, 3, 0, false).out_len(), 27);  // 33-6
}

TEST(Conv1d, RepeatedRunsAtTwoThreadsAreBitwiseEqual) {
  const int saved = t2m::get_num_threads();
  const Conv1dShape s = shape(4, 32, 48, 64, 3, 1, 1, 0, true);
  const auto x = to_float(randn(s.B * s.Cin * s.T, 61)), w = to_float(randn(s.Cout * s.Cin * s.K, 62));
  const auto b = to_float(randn(s.Cout, 63)), R = to_float(randn(s.B * s.Cout * s.out_len(), 64));
  auto run = [&](int threads) {
    t2m::set_num_threads(threads);
    std::vector<float> y(R.size()), dx(x.size()), dw(w.size(), 0), db(b.size(), 0);
    conv1d_forward<float>(y.data(), x.data(), w.data(), b.data(), s);
    conv1d_backward<float>(dx.data(), dw.data(), db.data(), R.data(), x.data(), w.data(), s);
    std::vector<float> all;
    for (auto* v : {&y, &dx, &dw, &db}) all.insert(all.end(), v->begin(), v->end());
    return all;
  };
  const auto a = run(2), a2 = run(2), one = run(1);
  t2m::set_num_threads(saved);
  EXPECT_TRUE(bitwise_equal(a, a2));
  expect_float_matches(a, to_double(one), 1e-5, "1 vs 2 threads");
}

TEST(Conv1d, BadConfigurationsThrow) {
  std::vector<float> buf(1024);
  float* p = buf.data();
  EXPECT_THROW(shape(1, 1, 1, 8, 3, 1, 1, 1, true).out_len(), t2m::Error);   // causal with pad
  EXPECT_THROW(shape(1, 1, 1, 4, 3, 1, 3, 0, false).out_len(), t2m::Error);  // span 7 > T 4
  EXPECT_THROW(shape(1, 1, 1, 8, 3, 0, 1, 0, false).out_len(), t2m::Error);  // stride 0
  EXPECT_THROW(shape(1, 1, 1, 8, 3, 1, 0, 0, false).out_len(), t2m::Error);  // dilation 0
  EXPECT_THROW(shape(1, 0, 1, 8, 3, 1, 1, 0, false).out_len(), t2m::Error);  // Cin 0
  EXPECT_THROW(shape(1, 1, 1, 8, 3, 1, 1, -1, false).out_len(), t2m::Error);
  EXPECT_THROW(causal_left(shape(1, 1, 1, 8, 3, 1, 1, 0, true), -2).out_len(), t2m::Error);
  EXPECT_THROW(causal_left(shape(1, 1, 1, 8, 3, 1, 1, 0, false), 2).out_len(), t2m::Error);  // not causal
  EXPECT_THROW(conv1d_forward<float>(p, p, nullptr, nullptr, shape(1, 1, 1, 8, 3, 1, 1, 0, false)), t2m::Error);
  EXPECT_THROW(conv1d_backward<float>(p, p, nullptr, nullptr, p, p, shape(1, 1, 1, 8, 3, 1, 1, 0, false)),
               t2m::Error);
  try {
    shape(1, 1, 1, 4, 3, 1, 3, 0, false).out_len();
    FAIL();
  } catch (const t2m::Error& e) {
    EXPECT_NE(std::string(e.what()).find("conv1d"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("T=4"), std::string::npos) << e.what();
  }
}

}  // namespace
