// test_ag_nn_ops.cpp — the differentiable wrappers of the fused kernels (norms, activations, dropout, conv1d,
// upsampling, embedding): values against naive double loops, float64 finite-difference gradchecks, float32
// against float64, and bad use throwing t2m::Error that names the op and the shapes.
#include <gtest/gtest.h>

#include <cmath>

#include "autograd/gradcheck.h"
#include "autograd/ops_norm.h"
#include "autograd/ops_reduce.h"
#include "autograd/ops_shape.h"
#include "autograd/ops_unary.h"
#include "tensor/ops.h"
#include "tensor/rng.h"
#include "test_tensor_util.h"

using namespace t2m;
using t2m::testing::expect_error;

namespace {

Tensor randn(const Shape& s, uint64_t seed, DType dt = DType::f64) {
  Generator g(seed);
  return rand_normal(s, g, 0.0, 1.0, dt);
}

void expect_gradcheck(const ag::GradcheckFn& f, const std::vector<Tensor>& in) {
  ag::GradcheckResult r = ag::gradcheck(f, in);
  EXPECT_TRUE(r.ok) << r.message;
}

// ---- naive references (double loops over contiguous copies) -------------------------------------------------

// x (N, C) rows; w, b (C) or undefined.
Tensor naive_layer_norm(const Tensor& x, const Tensor& w, const Tensor& b, double eps) {
  const int64_t C = x.size(-1), N = x.numel() / C;
  const Tensor xc = x.contiguous().view({N, C});
  Tensor out = Tensor::zeros({N, C}, DType::f64);
  for (int64_t n = 0; n < N; ++n) {
    double m = 0, v = 0;
    for (int64_t c = 0; c < C; ++c) m += xc.at({n, c});
    m /= (double)C;
    for (int64_t c = 0; c < C; ++c) v += (xc.at({n, c}) - m) * (xc.at({n, c}) - m);
    v /= (double)C;
    for (int64_t c = 0; c < C; ++c) {
      double y = (xc.at({n, c}) - m) / std::sqrt(v + eps);
      if (w.defined()) y *= w.at({c});
      if (b.defined()) y += b.at({c});
      out.set({n, c}, y);
    }
  }
  return out.view(x.shape());
}

Tensor naive_rms_norm(const Tensor& x, const Tensor& w, double eps) {
  const int64_t C = x.size(-1), N = x.numel() / C;
  const Tensor xc = x.contiguous().view({N, C});
  Tensor out = Tensor::zeros({N, C}, DType::f64);
  for (int64_t n = 0; n < N; ++n) {
    double ms = 0;
    for (int64_t c = 0; c < C; ++c) ms += xc.at({n, c}) * xc.at({n, c});
    ms /= (double)C;
    for (int64_t c = 0; c < C; ++c)
      out.set({n, c}, xc.at({n, c}) / std::sqrt(ms + eps) * (w.defined() ? w.at({c}) : 1.0));
  }
  return out.view(x.shape());
}

// x (B, C, T).
Tensor naive_group_norm(const Tensor& x, int64_t G, const Tensor& w, const Tensor& b, double eps) {
  const int64_t B = x.size(0), C = x.size(1), T = x.size(2), Cg = C / G;
  Tensor out = Tensor::zeros({B, C, T}, DType::f64);
  for (int64_t bi = 0; bi < B; ++bi)
    for (int64_t g = 0; g < G; ++g) {
      double m = 0, v = 0;
      for (int64_t c = g * Cg; c < (g + 1) * Cg; ++c)
        for (int64_t t = 0; t < T; ++t) m += x.at({bi, c, t});
      m /= (double)(Cg * T);
      for (int64_t c = g * Cg; c < (g + 1) * Cg; ++c)
        for (int64_t t = 0; t < T; ++t) v += (x.at({bi, c, t}) - m) * (x.at({bi, c, t}) - m);
      v /= (double)(Cg * T);
      for (int64_t c = g * Cg; c < (g + 1) * Cg; ++c)
        for (int64_t t = 0; t < T; ++t) {
          double y = (x.at({bi, c, t}) - m) / std::sqrt(v + eps);
          if (w.defined()) y *= w.at({c});
          if (b.defined()) y += b.at({c});
          out.set({bi, c, t}, y);
        }
    }
  return out;
}

ag::Variable var_or_none(const Tensor& t) { return t.defined() ? ag::Variable(t) : ag::Variable(); }

}  // namespace

// ---- norms ------------------------------------------------------------------------------------------------

TEST(AgNorm, LayerNormMatchesNaiveWithAndWithoutAffine) {
  const Tensor x = randn({2, 3, 8}, 1), w = randn({8}, 2), b = randn({8}, 3);
  for (int mode = 0; mode < 4; ++mode) {
    const Tensor ww = (mode & 1) ? w : Tensor(), bb = (mode & 2) ? b : Tensor();
    Tensor got = ag::layer_norm(ag::Variable(x), var_or_none(ww), var_or_none(bb), 1e-5).data();
    EXPECT_EQ(got.shape(), x.shape());
    EXPECT_LT(max_abs_diff(got, naive_layer_norm(x, ww, bb, 1e-5)), 1e-12) << "mode " << mode;
  }
  // float32 agrees with float64 to float precision; a transposed (strided) input works.
  Tensor got32 = ag::layer_norm(ag::Variable(x.to(DType::f32)), ag::Variable(w.to(DType::f32)),
                                ag::Variable(b.to(DType::f32)), 1e-5).data();
  EXPECT_LT(max_abs_diff(got32.to(DType::f64), naive_layer_norm(x, w, b, 1e-5)), 2e-5);
  const Tensor xt = randn({8, 5}, 4).transpose(0, 1);
  EXPECT_LT(max_abs_diff(ag::layer_norm(ag::Variable(xt), ag::Variable(w), ag::Variable(), 1e-5).data(),
                         naive_layer_norm(xt, w, Tensor(), 1e-5)), 1e-12);
}

TEST(AgNorm, LayerNormGradcheck) {
  expect_gradcheck([](const std::vector<ag::Variable>& v) { return ag::layer_norm(v[0], v[1], v[2], 1e-5); },
                   {randn({3, 5}, 5), randn({5}, 6), randn({5}, 7)});
  expect_gradcheck([](const std::vector<ag::Variable>& v) { return ag::layer_norm(v[0], ag::Variable(), ag::Variable(), 1e-5); },
                   {randn({2, 2, 4}, 8)});
  expect_gradcheck([](const std::vector<ag::Variable>& v) { return ag::layer_norm(v[0], v[1], ag::Variable(), 1e-3); },
                   {randn({4, 3}, 9), randn({3}, 10)});
}

TEST(AgNorm, RmsNormMatchesNaiveAndGradcheck) {
  const Tensor x = randn({3, 2, 6}, 11), w = randn({6}, 12);
  EXPECT_LT(max_abs_diff(ag::rms_norm(ag::Variable(x), ag::Variable(w), 1e-6).data(), naive_rms_norm(x, w, 1e-6)),
            1e-12);
  EXPECT_LT(max_abs_diff(ag::rms_norm(ag::Variable(x), ag::Variable(), 1e-6).data(),
                         naive_rms_norm(x, Tensor(), 1e-6)), 1e-12);
  Tensor got32 = ag::rms_norm(ag::Variable(x.to(DType::f32)), ag::Variable(w.to(DType::f32)), 1e-6).data();
  EXPECT_LT(max_abs_diff(got32.to(DType::f64), naive_rms_norm(x, w, 1e-6)), 2e-5);
  expect_gradcheck([](const std::vector<ag::Variable>& v) { return ag::rms_norm(v[0], v[1], 1e-6); },
                   {randn({3, 5}, 13), randn({5}, 14)});
  expect_gradcheck([](const std::vector<ag::Variable>& v) { return ag::rms_norm(v[0], ag::Variable(), 1e-6); },
                   {randn({2, 3, 4}, 15)});
}

TEST(AgNorm, GroupNormMatchesNaiveAndGradcheck) {
  const Tensor x = randn({2, 6, 5}, 16), w = randn({6}, 17), b = randn({6}, 18);
  for (int64_t G : {1, 2, 3, 6}) {
    EXPECT_LT(max_abs_diff(ag::group_norm(ag::Variable(x), G, ag::Variable(w), ag::Variable(b), 1e-5).data(),
                           naive_group_norm(x, G, w, b, 1e-5)), 1e-12) << "G " << G;
  }
  EXPECT_LT(max_abs_diff(ag::group_norm(ag::Variable(x), 3, ag::Variable(), ag::Variable(), 1e-5).data(),
                         naive_group_norm(x, 3, Tensor(), Tensor(), 1e-5)), 1e-12);
  Tensor got32 = ag::group_norm(ag::Variable(x.to(DType::f32)), 2, ag::Variable(w.to(DType::f32)),
                                ag::Variable(b.to(DType::f32)), 1e-5).data();
  EXPECT_LT(max_abs_diff(got32.to(DType::f64), naive_group_norm(x, 2, w, b, 1e-5)), 2e-5);
  expect_gradcheck([](const std::vector<ag::Variable>& v) { return ag::group_norm(v[0], 2, v[1], v[2], 1e-5); },
                   {randn({2, 4, 3}, 19), randn({4}, 20), randn({4}, 21)});
  expect_gradcheck([](const std::vector<ag::Variable>& v) {
    return ag::group_norm(ag::transpose(v[0], 1, 2), 3, ag::Variable(), ag::Variable(), 1e-5);
  }, {randn({1, 4, 6}, 22)});
}

TEST(AgNorm, OnlyWeightGradientWhenInputIsConstant) {
  ag::Variable x(randn({4, 3}, 23)), w(randn({3}, 24), true), b(randn({3}, 25), true);
  ag::sum(ag::square(ag::layer_norm(x, w, b, 1e-5))).backward();
  ASSERT_TRUE(w.grad().defined());
  ASSERT_TRUE(b.grad().defined());
  EXPECT_FALSE(x.grad().defined());
}

TEST(AgNorm, BadUseThrows) {
  ag::Variable x(randn({2, 4}, 26)), w5(randn({5}, 27));
  expect_error([&] { ag::layer_norm(x, w5, ag::Variable()); }, {"layer_norm", "weight", "[5]", "[2, 4]"});
  expect_error([&] { ag::layer_norm(x, ag::Variable(), w5); }, {"layer_norm", "bias", "[5]"});
  expect_error([&] { ag::layer_norm(x, ag::Variable(randn({4}, 1, DType::f32)), ag::Variable()); },
               {"layer_norm", "dtype", "f32"});
  expect_error([&] { ag::layer_norm(x, ag::Variable(), ag::Variable(), -1.0); }, {"layer_norm", "eps"});
  expect_error([&] { ag::rms_norm(x, w5); }, {"rms_norm", "weight", "[5]"});
  expect_error([&] { ag::rms_norm(ag::Variable(Tensor::zeros({2, 0})), ag::Variable()); }, {"rms_norm", "[2, 0]"});
  ag::Variable x3(randn({2, 6, 3}, 28));
  expect_error([&] { ag::group_norm(x3, 4, ag::Variable(), ag::Variable()); }, {"group_norm", "6", "4", "[2, 6, 3]"});
  expect_error([&] { ag::group_norm(ag::Variable(randn({6}, 1)), 2, ag::Variable(), ag::Variable()); },
               {"group_norm", "[6]"});
  expect_error([&] { ag::group_norm(ag::Variable(Tensor::zeros({2, 2, 2}, DType::i64)), 1, ag::Variable(), ag::Variable()); },
               {"group_norm", "i64"});
}
