// test_ag_nn_ops.cpp — the differentiable wrappers of the fused kernels (norms, activations, dropout, conv1d,
// upsampling, embedding): values against naive double loops, float64 finite-difference gradchecks, float32
// against float64, and bad use throwing t2m::Error that names the op and the shapes.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <utility>

#include "autograd/gradcheck.h"
#include "autograd/ops_activation.h"
#include "autograd/ops_conv.h"
#include "autograd/ops_elementwise.h"
#include "autograd/ops_embedding.h"
#include "autograd/ops_norm.h"
#include "autograd/ops_reduce.h"
#include "autograd/ops_shape.h"
#include "autograd/ops_unary.h"
#include "tensor/ops.h"
#include "tensor/rng.h"
#include "test_tensor_util.h"

using namespace t2m;
using t2m::testing::randn;
using t2m::testing::expect_error;

namespace {

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

// x (B, Cin, T), w (Cout, Cin, K), b (Cout) or undefined; zero padding (left, right) or causal replicate-left.
Tensor naive_conv1d(const Tensor& x, const Tensor& w, const Tensor& b, int64_t stride, int64_t dil,
                    ag::Conv1dPadding pad) {
  const int64_t B = x.size(0), Cin = x.size(1), T = x.size(2), Cout = w.size(0), K = w.size(2);
  const bool causal = pad.mode == ag::Conv1dPadding::Mode::causal_replicate;
  const int64_t L = causal && pad.left < 0 ? (K - 1) * dil : pad.left, R = causal ? 0 : pad.right;
  const int64_t To = (T + L + R - dil * (K - 1) - 1) / stride + 1;
  Tensor out = Tensor::zeros({B, Cout, To}, DType::f64);
  for (int64_t bi = 0; bi < B; ++bi)
    for (int64_t co = 0; co < Cout; ++co)
      for (int64_t to = 0; to < To; ++to) {
        double acc = b.defined() ? b.at({co}) : 0.0;
        for (int64_t ci = 0; ci < Cin; ++ci)
          for (int64_t k = 0; k < K; ++k) {
            int64_t t = to * stride - L + k * dil;
            if (causal && t < 0) t = 0;
            if (t < 0 || t >= T) continue;
            acc += w.at({co, ci, k}) * x.at({bi, ci, t});
          }
        out.set({bi, co, to}, acc);
      }
  return out;
}

double gelu_ref(double x) { return 0.5 * x * (1.0 + std::tanh(std::sqrt(2.0 / M_PI) * (x + 0.044715 * x * x * x))); }

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

TEST(AgNorm, GroupNormReluMatchesComposedAndGradcheck) {
  const Tensor x = randn({2, 6, 5}, 90), w = randn({6}, 91), b = randn({6}, 92);
  Tensor want = relu(naive_group_norm(x, 3, w, b, 1e-5));
  Tensor got = ag::group_norm_relu(ag::Variable(x), 3, ag::Variable(w), ag::Variable(b), 1e-5).data();
  EXPECT_LT(max_abs_diff(got, want), 1e-12);
  EXPECT_GT(sum(eq(got, Tensor::zeros({1}, DType::f64))).item(), 10.0);  // the ReLU is active somewhere
  // Output (the ReLU applied as the norm writes each row) and gradients equal those of the unfused composition
  // bit for bit (float32, threaded sizes).
  const Tensor xl = randn({4, 64, 200}, 93, DType::f32), wl = randn({64}, 94, DType::f32), bl = randn({64}, 95, DType::f32);
  const Tensor seed = randn({4, 64, 200}, 96, DType::f32);
  ag::Variable x1(xl, true), w1(wl, true), b1(bl, true), x2(xl, true), w2(wl, true), b2(bl, true);
  ag::Variable y1 = ag::group_norm_relu(x1, 8, w1, b1), y2 = ag::relu(ag::group_norm(x2, 8, w2, b2));
  EXPECT_EQ(std::memcmp(y1.data().data<float>(), y2.data().data<float>(), sizeof(float) * xl.numel()), 0);
  y1.backward(seed);
  y2.backward(seed);
  EXPECT_EQ(max_abs_diff(x1.grad(), x2.grad()), 0.0);
  EXPECT_EQ(max_abs_diff(w1.grad(), w2.grad()), 0.0);
  EXPECT_EQ(max_abs_diff(b1.grad(), b2.grad()), 0.0);
  {  // without weight and bias (the backward recomputes the output's sign from x and the statistics alone); one
     // constant group normalises to exactly 0, where the ReLU passes no gradient
    Tensor xz = xl.clone();
    for (int64_t i = 0; i < 8 * 200; ++i) xz.data<float>()[i] = 0.5f;
    ag::Variable x3(xz, true), x4(xz, true);
    ag::Variable y3 = ag::group_norm_relu(x3, 8, ag::Variable(), ag::Variable());
    ag::Variable y4 = ag::relu(ag::group_norm(x4, 8, ag::Variable(), ag::Variable()));
    EXPECT_EQ(std::memcmp(y3.data().data<float>(), y4.data().data<float>(), sizeof(float) * xl.numel()), 0);
    EXPECT_EQ(y3.data().data<float>()[0], 0.0f);
    y3.backward(seed);
    y4.backward(seed);
    EXPECT_EQ(max_abs_diff(x3.grad(), x4.grad()), 0.0);
  }
  expect_gradcheck([](const std::vector<ag::Variable>& v) { return ag::group_norm_relu(v[0], 2, v[1], v[2], 1e-5); },
                   {randn({2, 4, 3}, 97), randn({4}, 98), randn({4}, 99)});
  expect_error([] { ag::group_norm_relu(ag::Variable(randn({2, 6, 3}, 1)), 4, ag::Variable(), ag::Variable()); },
               {"group_norm_relu", "groups = 4"});
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

// ---- activations and dropout -------------------------------------------------------------------------------

TEST(AgActivation, GeluTanhAndSiluMatchFormulas) {
  const Tensor x = randn({3, 7}, 30);
  Tensor g = ag::gelu_tanh(ag::Variable(x)).data(), s = ag::silu(ag::Variable(x)).data();
  double eg = 0, es = 0;
  for (int64_t i = 0; i < 3; ++i)
    for (int64_t j = 0; j < 7; ++j) {
      const double v = x.at({i, j});
      eg = std::max(eg, std::fabs(g.at({i, j}) - gelu_ref(v)));
      es = std::max(es, std::fabs(s.at({i, j}) - v / (1.0 + std::exp(-v))));
    }
  EXPECT_LT(eg, 1e-14);
  EXPECT_LT(es, 1e-14);
  // float32 (vectorised tanh) agrees with float64; large tensors take the threaded path.
  const Tensor xl = randn({300, 300}, 31);
  for (auto op : {&ag::gelu_tanh, &ag::silu}) {
    Tensor y64 = op(ag::Variable(xl)).data();
    Tensor y32 = op(ag::Variable(xl.to(DType::f32))).data();
    EXPECT_LT(max_abs_diff(y32.to(DType::f64), y64), 1e-5);
  }
}

TEST(AgActivation, Gradcheck) {
  expect_gradcheck([](const std::vector<ag::Variable>& v) { return ag::gelu_tanh(v[0]); }, {randn({4, 5}, 32)});
  expect_gradcheck([](const std::vector<ag::Variable>& v) { return ag::silu(v[0]); }, {randn({4, 5}, 33)});
  expect_gradcheck([](const std::vector<ag::Variable>& v) { return ag::silu(ag::transpose(v[0], 0, 1)); },
                   {randn({3, 4}, 34)});
  expect_error([] { ag::silu(ag::Variable(Tensor::zeros({2}, DType::i64))); }, {"silu", "i64", "[2]"});
  expect_error([] { ag::gelu_tanh(ag::Variable(Tensor::zeros({2}, DType::i64))); }, {"gelu_tanh", "i64"});
}

TEST(AgDropout, MaskIsPhiloxBernoulliScaledAndDeterministic) {
  const Tensor x = randn({8, 50}, 35);
  Generator g1(77), ref(77);
  ag::Variable y = ag::dropout(ag::Variable(x), 0.3, g1, true);
  const Tensor keep = rand_bernoulli({8, 50}, ref, 0.7, DType::f64);
  EXPECT_EQ(g1.offset(), ref.offset());  // advances exactly like the mask draw
  EXPECT_LT(max_abs_diff(y.data(), mul(mul(x, keep), 1.0 / 0.7)), 1e-15);
  const double kept = sum(keep).item() / 400.0;
  EXPECT_GT(kept, 0.6);
  EXPECT_LT(kept, 0.8);
  Generator g2(77), g3(78);
  EXPECT_EQ(max_abs_diff(ag::dropout(ag::Variable(x), 0.3, g2, true).data(), y.data()), 0.0);
  EXPECT_GT(max_abs_diff(ag::dropout(ag::Variable(x), 0.3, g3, true).data(), y.data()), 0.0);
  // The next call continues the stream: a different mask.
  EXPECT_GT(max_abs_diff(ag::dropout(ag::Variable(x), 0.3, g1, true).data(), y.data()), 0.0);
  // A large float32 tensor (threaded path) gives the same mask as the serial Bernoulli draw.
  const Tensor xl = randn({300, 301}, 38, DType::f32);
  Generator gl(5), refl(5);
  Tensor yl = ag::dropout(ag::Variable(xl), 0.1, gl, true).data();
  const Tensor keepl = rand_bernoulli({300, 301}, refl, 0.9, DType::f32);
  EXPECT_EQ(max_abs_diff(yl, mul(xl, mul(keepl, 1.0 / 0.9))), 0.0);
}

TEST(AgDropout, EvalIdentityGradientAndEdgeCases) {
  ag::Variable x(randn({4, 6}, 36), true);
  Generator g(5);
  ag::Variable same = ag::dropout(x, 0.5, g, false);
  EXPECT_EQ(same.impl(), x.impl());
  EXPECT_EQ(g.offset(), 0u);
  EXPECT_EQ(ag::dropout(x, 0.0, g, true).impl(), x.impl());
  // Gradient = mask / (1 - p).
  Generator gm(9), ref(9);
  ag::sum(ag::dropout(x, 0.25, gm, true)).backward();
  EXPECT_LT(max_abs_diff(x.grad(), mul(rand_bernoulli({4, 6}, ref, 0.75, DType::f64), 1.0 / 0.75)), 1e-15);
  // p = 1 drops everything.
  Generator g1(3);
  EXPECT_EQ(amax(abs(ag::dropout(x, 1.0, g1, true).data())).item(), 0.0);
  expect_gradcheck([](const std::vector<ag::Variable>& v) {
    Generator gg(11);  // same mask for every evaluation
    return ag::dropout(v[0], 0.4, gg, true);
  }, {randn({3, 5}, 37)});
  expect_error([&] { ag::dropout(x, 1.5, g, true); }, {"dropout", "1.5", "[4, 6]"});
  expect_error([&] { ag::dropout(x, -0.1, g, false); }, {"dropout", "p must be"});
}

TEST(AgDropout, ResidualFormIsAddOfDropoutBitForBit) {
  // float32 large (threaded, several Philox chunks, a ragged tail) and small; p = 1e-12 keeps every element.
  for (const auto& [shape, p] : {std::pair{Shape{300, 301}, 0.1}, std::pair{Shape{3, 7}, 0.3},
                                 std::pair{Shape{5, 77}, 1e-12}, std::pair{Shape{4, 9}, 1.0}}) {
    const Tensor x = randn(shape, 50, DType::f32), h = randn(shape, 51, DType::f32);
    const Tensor g = randn(shape, 52, DType::f32);
    ag::Variable xa(x, true), ha(h, true), xb(x, true), hb(h, true);
    Generator g1(21), g2(21);
    ag::Variable y1 = ag::residual_dropout(xa, ha, p, g1, true);
    ag::Variable y2 = ag::add(xb, ag::dropout(hb, p, g2, true));
    EXPECT_EQ(g1.offset(), g2.offset());
    ASSERT_EQ(y1.shape(), y2.shape());
    EXPECT_EQ(std::memcmp(y1.data().data<float>(), y2.data().data<float>(), sizeof(float) * x.numel()), 0);
    ag::sum(ag::mul(y1, ag::Variable(g))).backward();
    ag::sum(ag::mul(y2, ag::Variable(g))).backward();
    EXPECT_EQ(std::memcmp(xa.grad().data<float>(), xb.grad().data<float>(), sizeof(float) * x.numel()), 0);
    EXPECT_EQ(std::memcmp(ha.grad().data<float>(), hb.grad().data<float>(), sizeof(float) * x.numel()), 0);
  }
  // The value: x + mask * h / (1 - p), the mask the Bernoulli draw.
  const Tensor x = randn({6, 40}, 53), h = randn({6, 40}, 54);
  Generator gr(8), ref(8);
  const Tensor keep = rand_bernoulli({6, 40}, ref, 0.75, DType::f64);
  EXPECT_LT(max_abs_diff(ag::residual_dropout(ag::Variable(x), ag::Variable(h), 0.25, gr, true).data(),
                         add(x, mul(mul(h, keep), 1.0 / 0.75))),
            1e-15);
  expect_gradcheck([](const std::vector<ag::Variable>& v) {
    Generator gg(11);  // same mask for every evaluation
    return ag::residual_dropout(v[0], v[1], 0.4, gg, true);
  }, {randn({3, 5}, 55), randn({3, 5}, 56)});
  // Eval mode, p = 0 and a broadcast x: the add of the two ops (generator untouched when not dropping).
  Generator ge(3);
  EXPECT_EQ(max_abs_diff(ag::residual_dropout(ag::Variable(x), ag::Variable(h), 0.5, ge, false).data(), add(x, h)),
            0.0);
  EXPECT_EQ(ge.offset(), 0u);
  const Tensor row = randn({1, 40}, 57);
  Generator gb(4), gb2(4);
  EXPECT_EQ(max_abs_diff(ag::residual_dropout(ag::Variable(row), ag::Variable(h), 0.2, gb, true).data(),
                         ag::add(ag::Variable(row), ag::dropout(ag::Variable(h), 0.2, gb2, true)).data()),
            0.0);
  expect_error([&] { ag::residual_dropout(ag::Variable(x), ag::Variable(h), 1.5, ge, true); },
               {"residual_dropout", "1.5", "[6, 40]"});
  expect_error([&] { ag::residual_dropout(ag::Variable(x), ag::Variable(Tensor::zeros({6, 40}, DType::i64)), 0.1, ge,
                                          true); },
               {"residual_dropout", "i64"});
}

// ---- conv1d and upsampling ---------------------------------------------------------------------------------

TEST(AgConv, MatchesNaiveAllPaddingModes) {
  const Tensor x = randn({2, 3, 11}, 40), w = randn({4, 3, 3}, 41), b = randn({4}, 42);
  struct Case { int64_t stride, dil; ag::Conv1dPadding pad; bool bias; };
  const std::vector<Case> cases = {
      {1, 1, ag::Conv1dPadding::same_zeros(1), true},  {2, 1, ag::Conv1dPadding::same_zeros(1), true},
      {1, 3, ag::Conv1dPadding::causal(), true},       {2, 2, ag::Conv1dPadding::causal(), false},
      {1, 1, ag::Conv1dPadding::zeros(2, 0), true},    {2, 1, ag::Conv1dPadding::zeros(0, 3), false},
      {3, 2, ag::Conv1dPadding::zeros(1, 2), true},    {1, 1, ag::Conv1dPadding::same_zeros(0), true},
      {2, 1, ag::Conv1dPadding::causal(1), true},      {2, 2, ag::Conv1dPadding::causal(5), false},
      {1, 1, ag::Conv1dPadding::causal(0), true}};
  for (const auto& c : cases) {
    const Tensor bb = c.bias ? b : Tensor();
    Tensor want = naive_conv1d(x, w, bb, c.stride, c.dil, c.pad);
    Tensor got = ag::conv1d(ag::Variable(x), ag::Variable(w), var_or_none(bb), c.stride, c.dil, c.pad).data();
    ASSERT_EQ(got.shape(), want.shape()) << "stride " << c.stride << " dil " << c.dil;
    EXPECT_LT(max_abs_diff(got, want), 1e-12) << "stride " << c.stride << " dil " << c.dil << " left "
                                              << c.pad.left << " right " << c.pad.right;
    Tensor got32 = ag::conv1d(ag::Variable(x.to(DType::f32)), ag::Variable(w.to(DType::f32)),
                              var_or_none(c.bias ? b.to(DType::f32) : Tensor()), c.stride, c.dil, c.pad).data();
    EXPECT_LT(max_abs_diff(got32.to(DType::f64), want), 1e-4);
  }
  // Causal: output frame t depends on input frames <= t only (changing the future changes nothing before it).
  Tensor x2 = x.clone();
  x2.set({0, 1, 7}, 100.0);
  Tensor y1 = ag::conv1d(ag::Variable(x), ag::Variable(w), ag::Variable(b), 1, 2, ag::Conv1dPadding::causal()).data();
  Tensor y2 = ag::conv1d(ag::Variable(x2), ag::Variable(w), ag::Variable(b), 1, 2, ag::Conv1dPadding::causal()).data();
  EXPECT_EQ(max_abs_diff(y1.narrow(2, 0, 7), y2.narrow(2, 0, 7)), 0.0);
  EXPECT_GT(max_abs_diff(y1.narrow(2, 7, 1), y2.narrow(2, 7, 1)), 0.0);
}

TEST(AgConv, Gradcheck) {
  auto f = [](int64_t stride, int64_t dil, ag::Conv1dPadding pad, bool bias) {
    return [=](const std::vector<ag::Variable>& v) {
      return ag::conv1d(v[0], v[1], bias ? v[2] : ag::Variable(), stride, dil, pad);
    };
  };
  const Tensor x = randn({2, 2, 7}, 43), w = randn({3, 2, 3}, 44), b = randn({3}, 45);
  expect_gradcheck(f(1, 1, ag::Conv1dPadding::same_zeros(1), true), {x, w, b});
  expect_gradcheck(f(2, 1, ag::Conv1dPadding::same_zeros(1), true), {x, w, b});
  expect_gradcheck(f(1, 2, ag::Conv1dPadding::causal(), true), {x, w, b});
  expect_gradcheck(f(2, 3, ag::Conv1dPadding::causal(), false), {x, w});
  expect_gradcheck(f(2, 1, ag::Conv1dPadding::zeros(2, 1), true), {x, w, b});
  expect_gradcheck(f(2, 1, ag::Conv1dPadding::causal(1), true), {x, w, b});   // anchor: (K-1)d + 1 - stride
  expect_gradcheck(f(1, 1, ag::Conv1dPadding::causal(4), false), {x, w});
  expect_gradcheck(f(1, 1, ag::Conv1dPadding::zeros(0, 0), false), {x, randn({2, 2, 1}, 46)});
  // Strided input (a transposed view).
  expect_gradcheck([](const std::vector<ag::Variable>& v) {
    return ag::conv1d(ag::transpose(v[0], 1, 2), v[1], ag::Variable(), 1, 1, ag::Conv1dPadding::causal());
  }, {randn({1, 6, 2}, 47), randn({2, 2, 2}, 48)});
}

TEST(AgConv, UpsampleNearestValuesAndGradcheck) {
  const Tensor x = randn({2, 3, 4}, 50);
  Tensor y = ag::upsample_nearest1d(ag::Variable(x), 2).data();
  ASSERT_EQ(y.shape(), (Shape{2, 3, 8}));
  double err = 0;
  for (int64_t b = 0; b < 2; ++b)
    for (int64_t c = 0; c < 3; ++c)
      for (int64_t t = 0; t < 8; ++t) err = std::max(err, std::fabs(y.at({b, c, t}) - x.at({b, c, t / 2})));
  EXPECT_EQ(err, 0.0);
  expect_gradcheck([](const std::vector<ag::Variable>& v) { return ag::upsample_nearest1d(v[0], 3); },
                   {randn({2, 2, 3}, 51)});
  expect_error([] { ag::upsample_nearest1d(ag::Variable(randn({2, 3}, 1)), 2); }, {"upsample_nearest1d", "[2, 3]"});
  expect_error([] { ag::upsample_nearest1d(ag::Variable(randn({1, 2, 3}, 1)), 0); }, {"upsample_nearest1d", "scale"});
}

TEST(AgConv, BadUseThrows) {
  ag::Variable x(randn({2, 3, 5}, 52)), w(randn({4, 3, 3}, 53));
  expect_error([&] { ag::conv1d(ag::Variable(randn({3, 5}, 1)), w, ag::Variable()); }, {"conv1d", "3-D", "[3, 5]"});
  expect_error([&] { ag::conv1d(x, ag::Variable(randn({4, 2, 3}, 1)), ag::Variable()); },
               {"conv1d", "Cin", "[2, 3, 5]", "[4, 2, 3]"});
  expect_error([&] { ag::conv1d(x, w, ag::Variable(randn({3}, 1))); }, {"conv1d", "bias", "[3]"});
  expect_error([&] { ag::conv1d(x, w, ag::Variable(), 0); }, {"conv1d", "stride"});
  expect_error([&] { ag::conv1d(x, w, ag::Variable(), 1, 1, ag::Conv1dPadding::zeros(-1, 0)); }, {"conv1d", "padding"});
  expect_error([&] { ag::conv1d(x, w, ag::Variable(), 1, 3); }, {"conv1d", "[2, 3, 5]"});  // To < 1
  expect_error([&] { ag::conv1d(x, ag::Variable(randn({4, 3, 3}, 1, DType::f32)), ag::Variable()); },
               {"conv1d", "dtype"});
}

// ---- embedding ---------------------------------------------------------------------------------------------

TEST(AgEmbedding, GatherValuesScatterAddBackwardAndGradcheck) {
  const Tensor w = randn({5, 3}, 60);
  const Tensor ids = Tensor::from_vector(std::vector<int64_t>{4, 0, 4, 2, 4, 1}, {2, 3});
  ag::Variable wv(w, true);
  ag::Variable y = ag::embedding(wv, ids);
  ASSERT_EQ(y.shape(), (Shape{2, 3, 3}));
  for (int64_t i = 0; i < 2; ++i)
    for (int64_t j = 0; j < 3; ++j)
      for (int64_t d = 0; d < 3; ++d)
        EXPECT_EQ(y.data().at({i, j, d}), w.at({(int64_t)ids.at({i, j}), d}));
  ag::sum(y).backward();
  // Row 4 used three times, rows 0, 1, 2 once, row 3 never.
  EXPECT_EQ(wv.grad().select(1, 0).to_vector<double>(), (std::vector<double>{1, 1, 1, 0, 3}));
  expect_gradcheck([ids](const std::vector<ag::Variable>& v) { return ag::embedding(v[0], ids); }, {w});
  const Tensor scalar_id = Tensor::from_vector(std::vector<int64_t>{3}, {1}).view({});
  EXPECT_EQ(ag::embedding(ag::Variable(w), scalar_id).shape(), (Shape{3}));
  // Large enough to take the threaded backward: same as a serial reference.
  Generator g(61);
  const Tensor big_ids = randint({4000}, g, 0, 50);
  ag::Variable bw(randn({50, 64}, 62), true);
  ag::sum(ag::mul(ag::embedding(bw, big_ids), ag::Variable(randn({4000, 64}, 63)))).backward();
  Tensor ref = Tensor::zeros({50, 64}, DType::f64);
  const Tensor gw = randn({4000, 64}, 63);
  for (int64_t n = 0; n < 4000; ++n) {
    Tensor row = ref.select(0, (int64_t)big_ids.at({n}));
    add_(row, gw.select(0, n));
  }
  EXPECT_LT(max_abs_diff(bw.grad(), ref), 1e-12);
}

TEST(AgEmbedding, BadUseThrows) {
  ag::Variable w(randn({5, 3}, 64));
  expect_error([&] { ag::embedding(w, Tensor::from_vector(std::vector<int64_t>{1, 5}, {2})); },
               {"embedding", "id 5", "V = 5"});
  expect_error([&] { ag::embedding(w, Tensor::from_vector(std::vector<int64_t>{-1}, {1})); }, {"embedding", "id -1"});
  expect_error([&] { ag::embedding(w, Tensor::zeros({2})); }, {"embedding", "int64", "f32"});
  expect_error([&] { ag::embedding(ag::Variable(randn({5}, 1)), Tensor::zeros({2}, DType::i64)); },
               {"embedding", "[5]"});
}

TEST(AgConv, OnlyRequestedGradientsAndEmptyBatch) {
  // x constant: only the weight/bias gradients; weight constant: only dx (which equals the full computation's).
  const Tensor xt = randn({2, 3, 6}, 70), wt = randn({4, 3, 3}, 71), bt = randn({4}, 72);
  ag::Variable x1(xt), w1(wt, true), b1(bt, true);
  ag::sum(ag::conv1d(x1, w1, b1, 1, 2, ag::Conv1dPadding::causal())).backward();
  EXPECT_FALSE(x1.grad().defined());
  ag::Variable x2(xt, true), w2(wt), b2(bt);
  ag::sum(ag::conv1d(x2, w2, b2, 1, 2, ag::Conv1dPadding::causal())).backward();
  EXPECT_FALSE(w2.grad().defined());
  ag::Variable x3(xt, true), w3(wt, true), b3(bt, true);
  ag::sum(ag::conv1d(x3, w3, b3, 1, 2, ag::Conv1dPadding::causal())).backward();
  EXPECT_EQ(max_abs_diff(x2.grad(), x3.grad()), 0.0);
  EXPECT_EQ(max_abs_diff(w1.grad(), w3.grad()), 0.0);
  EXPECT_EQ(max_abs_diff(b1.grad(), b3.grad()), 0.0);
  // B = 0: an empty output of the right shape, zero parameter gradients.
  ag::Variable xe(Tensor::zeros({0, 3, 6}, DType::f64), true);
  ag::Variable ye = ag::conv1d(xe, w3, b3, 2, 1, ag::Conv1dPadding::zeros(1, 2));
  EXPECT_EQ(ye.shape(), (Shape{0, 4, 4}));
  w3.zero_grad();
  ag::sum(ye).backward();
  EXPECT_EQ(amax(abs(w3.grad())).item(), 0.0);
  EXPECT_EQ(xe.grad().shape(), (Shape{0, 3, 6}));
}
