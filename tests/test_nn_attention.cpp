// test_nn_attention.cpp — MultiheadAttention (self and cross) and the adaLN pieces: parameter names/shapes as in
// torch_ref.py, values against naive per-element loops written from the PyTorch code, float64 finite-difference
// checks of the gradients of inputs AND parameters, masks/causality at module level, bad use throws.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "autograd/gradcheck.h"
#include "autograd/ops_reduce.h"
#include "nn/adaln.h"
#include "nn/attention.h"
#include "tensor/ops.h"
#include "tensor/rng.h"
#include "test_tensor_util.h"

using namespace t2m;
using t2m::testing::randn;
using t2m::testing::expect_error;

namespace {

// Central differences of L = sum(f() * W) w.r.t. every element of every tensor in `wrt` (module parameters and
// inputs, float64), compared with the gradients backward() leaves in `grads_of`.
void fd_check(const std::function<ag::Variable()>& f, const std::vector<ag::Variable>& wrt, double tol = 1e-6) {
  for (const auto& v : wrt) v.clear_grad();
  ag::Variable y = f();
  const Tensor w = randn(y.shape(), 1234);
  y.backward(w);
  auto loss = [&] { return t2m::sum(t2m::mul(f().data(), w)).item(); };
  const double eps = 1e-6;
  for (size_t i = 0; i < wrt.size(); ++i) {
    Tensor& x = wrt[i].data();
    ASSERT_TRUE(wrt[i].grad().defined()) << "no gradient for tensor " << i << " " << wrt[i].name();
    const Tensor g = wrt[i].grad().contiguous();
    double* p = x.data<double>();
    for (int64_t j = 0; j < x.numel(); ++j) {
      const double old = p[j];
      p[j] = old + eps;
      const double lp = loss();
      p[j] = old - eps;
      const double lm = loss();
      p[j] = old;
      const double num = (lp - lm) / (2 * eps), ana = g.data<double>()[j];
      ASSERT_NEAR(ana, num, tol * (1 + std::abs(num))) << "tensor " << i << " (" << wrt[i].name() << ") element " << j;
    }
  }
}

std::vector<ag::Variable> params_and(const nn::Module& m, const std::vector<ag::Variable>& extra) {
  std::vector<ag::Variable> r = m.parameters();
  r.insert(r.end(), extra.begin(), extra.end());
  return r;
}

Tensor param(const nn::Module& m, const std::string& name) {
  for (auto& [n, v] : m.named_parameters())
    if (n == name) return v.data();
  ADD_FAILURE() << "no parameter " << name;
  return Tensor();
}

// y[b,t,o] = sum_i x[b,t,i] W[o,i] + bias[o]
std::vector<double> naive_linear(const Tensor& x, const Tensor& W, const Tensor& bias, int64_t b, int64_t t) {
  std::vector<double> y(W.size(0));
  for (int64_t o = 0; o < W.size(0); ++o) {
    double acc = bias.defined() ? bias.at({o}) : 0.0;
    for (int64_t i = 0; i < W.size(1); ++i) acc += x.at({b, t, i}) * W.at({o, i});
    y[o] = acc;
  }
  return y;
}

// The module computed naively from torch_ref.py's code, per element, in double.
Tensor naive_mha(const nn::MultiheadAttention& m, const Tensor& x, const Tensor& ctx, const Tensor& mask,
                 int64_t pos0) {
  const auto& c = m.config();
  const int64_t B = x.size(0), T = x.size(1), D = c.dim, H = c.heads, d = D / H;
  const Tensor& src = c.cross ? ctx : x;
  const int64_t S = src.size(1);
  // rows of q (B,T,D) and k, v (B,S,D) in (b, t, h*d + i) layout
  std::vector<double> q(B * T * D), k(B * S * D), v(B * S * D);
  for (int64_t b = 0; b < B; ++b) {
    for (int64_t t = 0; t < T; ++t) {
      auto r = c.cross ? naive_linear(x, param(m, "q.weight"), c.qkv_bias ? param(m, "q.bias") : Tensor(), b, t)
                       : naive_linear(x, param(m, "qkv.weight"), c.qkv_bias ? param(m, "qkv.bias") : Tensor(), b, t);
      for (int64_t j = 0; j < D; ++j) q[(b * T + t) * D + j] = r[j];
      if (!c.cross)
        for (int64_t j = 0; j < D; ++j) k[(b * S + t) * D + j] = r[D + j], v[(b * S + t) * D + j] = r[2 * D + j];
    }
    if (c.cross)
      for (int64_t s = 0; s < S; ++s) {
        auto r = naive_linear(ctx, param(m, "kv.weight"), c.qkv_bias ? param(m, "kv.bias") : Tensor(), b, s);
        for (int64_t j = 0; j < D; ++j) k[(b * S + s) * D + j] = r[j], v[(b * S + s) * D + j] = r[D + j];
      }
  }
  auto head_transform = [&](std::vector<double>& a, int64_t L, const char* wname) {
    for (int64_t row = 0; row < B * L; ++row)
      for (int64_t h = 0; h < H; ++h) {
        double* e = &a[row * D + h * d];
        if (c.qk_norm) {
          double ms = 0;
          for (int64_t i = 0; i < d; ++i) ms += e[i] * e[i] / d;
          const Tensor w = param(m, wname);
          for (int64_t i = 0; i < d; ++i) e[i] = e[i] / std::sqrt(ms + c.norm_eps) * w.at({i});
        }
        if (c.rope) {
          const int64_t pos = pos0 + row % L;
          for (int64_t i = 0; i < d / 2; ++i) {
            const double ang = pos * std::pow(10000.0, -2.0 * i / d), a0 = e[i], a1 = e[i + d / 2];
            e[i] = a0 * std::cos(ang) - a1 * std::sin(ang);
            e[i + d / 2] = a0 * std::sin(ang) + a1 * std::cos(ang);
          }
        }
      }
  };
  head_transform(q, T, "qn.weight");
  head_transform(k, S, "kn.weight");
  Tensor o = Tensor::zeros({B, T, D}, DType::f64);
  for (int64_t b = 0; b < B; ++b)
    for (int64_t h = 0; h < H; ++h)
      for (int64_t t = 0; t < T; ++t) {
        std::vector<double> p(S, 0.0);
        double mx = -INFINITY, z = 0;
        auto vis = [&](int64_t s) { return (!mask.defined() || mask.at({b, s}) != 0) && (!c.causal || s <= t); };
        for (int64_t s = 0; s < S; ++s) {
          for (int64_t i = 0; i < d; ++i) p[s] += q[(b * T + t) * D + h * d + i] * k[(b * S + s) * D + h * d + i];
          p[s] /= std::sqrt((double)d);
          if (vis(s)) mx = std::max(mx, p[s]);
        }
        for (int64_t s = 0; s < S; ++s) z += (p[s] = vis(s) ? std::exp(p[s] - mx) : 0.0);
        for (int64_t i = 0; i < d; ++i) {
          double acc = 0;
          for (int64_t s = 0; s < S; ++s) acc += p[s] / z * v[(b * S + s) * D + h * d + i];
          o.set({b, t, h * d + i}, acc);
        }
      }
  Tensor out = Tensor::zeros({B, T, D}, DType::f64);
  for (int64_t b = 0; b < B; ++b)
    for (int64_t t = 0; t < T; ++t) {
      auto r = naive_linear(o, param(m, "proj.weight"), param(m, "proj.bias"), b, t);
      for (int64_t j = 0; j < D; ++j) out.set({b, t, j}, r[j]);
    }
  return out;
}

std::vector<std::string> names_of(const nn::Module& m) {
  std::vector<std::string> r;
  for (auto& kv : m.named_parameters()) r.push_back(kv.first + shape_str(kv.second.shape()));
  return r;
}

}  // namespace

TEST(NnAttention, SelfParameterNamesFollowTorchRef) {
  Generator g(1);
  nn::MultiheadAttention m({.dim = 8, .heads = 2, .qk_norm = true, .rope = true}, g);
  EXPECT_EQ(names_of(m), (std::vector<std::string>{"qkv.weight[24, 8]", "qkv.bias[24]", "qn.weight[4]",
                                                    "kn.weight[4]", "proj.weight[8, 8]", "proj.bias[8]"}));
  nn::MultiheadAttention plain({.dim = 8, .heads = 2, .qkv_bias = false}, g);
  EXPECT_EQ(names_of(plain), (std::vector<std::string>{"qkv.weight[24, 8]", "proj.weight[8, 8]", "proj.bias[8]"}));
  nn::MultiheadAttention x({.dim = 8, .heads = 2, .cross = true, .ctx_dim = 6, .qk_norm = true}, g);
  EXPECT_EQ(names_of(x), (std::vector<std::string>{"q.weight[8, 8]", "q.bias[8]", "kv.weight[16, 6]", "kv.bias[16]",
                                                "qn.weight[4]", "kn.weight[4]", "proj.weight[8, 8]", "proj.bias[8]"}));
  // same seed, same weights
  Generator g1(7), g2(7);
  nn::MultiheadAttention a({.dim = 8, .heads = 2}, g1), b({.dim = 8, .heads = 2}, g2);
  EXPECT_EQ(max_abs_diff(param(a, "qkv.weight"), param(b, "qkv.weight")), 0.0);
  EXPECT_EQ(max_abs_diff(param(a, "proj.bias"), param(b, "proj.bias")), 0.0);
}

TEST(NnAttention, SelfMatchesNaiveTorchRefCode) {
  Generator g(2);
  nn::MultiheadAttention m({.dim = 8, .heads = 2, .qk_norm = true, .rope = true}, g);
  m.to(DType::f64);
  for (auto& p : m.parameters()) p.data().copy_(randn(p.shape(), 100 + p.numel()));  // non-trivial norm weights
  const Tensor x = randn({2, 5, 8}, 3);
  for (int64_t pos0 : {0, 4}) {
    Tensor y = m.forward(ag::Variable(x), Tensor(), pos0).data();
    EXPECT_EQ(y.shape(), (Shape{2, 5, 8}));
    EXPECT_LT(max_abs_diff(y, naive_mha(m, x, Tensor(), Tensor(), pos0)), 1e-11);
  }
  // key padding mask and causal variants
  Tensor mask = Tensor::ones({2, 5}, DType::f64);
  mask.set({1, 4}, 0.0);
  mask.set({1, 2}, 0.0);
  EXPECT_LT(max_abs_diff(m.forward(ag::Variable(x), mask).data(), naive_mha(m, x, Tensor(), mask, 0)), 1e-11);
  Generator g2(3);
  nn::MultiheadAttention c({.dim = 8, .heads = 4, .qkv_bias = false, .causal = true}, g2);
  c.to(DType::f64);
  EXPECT_LT(max_abs_diff(c.forward(ag::Variable(x)).data(), naive_mha(c, x, Tensor(), Tensor(), 0)), 1e-11);
}

TEST(NnAttention, CrossWithOtherContextLengthAndDim) {
  Generator g(4);
  nn::MultiheadAttention m({.dim = 6, .heads = 3, .cross = true, .ctx_dim = 10, .qk_norm = true}, g);
  m.to(DType::f64);
  const Tensor x = randn({2, 3, 6}, 5), ctx = randn({2, 7, 10}, 6);
  Tensor mask = Tensor::ones({2, 7}, DType::f64);
  for (int64_t s = 4; s < 7; ++s) mask.set({0, s}, 0.0);
  Tensor y = m.forward_cross(ag::Variable(x), ag::Variable(ctx), mask).data();
  EXPECT_EQ(y.shape(), (Shape{2, 3, 6}));
  EXPECT_LT(max_abs_diff(y, naive_mha(m, x, ctx, mask, 0)), 1e-11);
  // masked context tokens have no influence
  Tensor ctx2 = ctx.clone();
  for (int64_t j = 0; j < 10; ++j) ctx2.set({0, 5, j}, 40.0);
  EXPECT_EQ(max_abs_diff(m.forward_cross(ag::Variable(x), ag::Variable(ctx2), mask).data(), y), 0.0);
}

TEST(NnAttention, GradientsOfInputsAndParametersFloat64) {
  Generator g(8);
  nn::MultiheadAttention s({.dim = 4, .heads = 2, .qk_norm = true, .rope = true, .causal = true}, g);
  s.to(DType::f64);
  ag::Variable x(randn({2, 3, 4}, 9), true);
  Tensor mask = Tensor::ones({2, 3}, DType::f64);
  mask.set({1, 1}, 0.0);
  fd_check([&] { return s.forward(x, mask, 1); }, params_and(s, {x}));
  nn::MultiheadAttention c({.dim = 4, .heads = 2, .cross = true, .ctx_dim = 3, .qk_norm = true}, g);
  c.to(DType::f64);
  ag::Variable ctx(randn({2, 5, 3}, 10), true);
  fd_check([&] { return c.forward_cross(x, ctx); }, params_and(c, {x, ctx}));
}

TEST(NnAttention, CausalModuleIgnoresTheFuture) {
  Generator g(11);
  nn::MultiheadAttention m({.dim = 4, .heads = 2, .qk_norm = true, .rope = true, .causal = true}, g);
  const Tensor x = randn({1, 6, 4}, 12, DType::f32);
  Tensor x2 = x.clone();
  for (int64_t j = 0; j < 4; ++j) x2.set({0, 4, j}, 9.0), x2.set({0, 5, j}, -9.0);
  Tensor a = m.forward(ag::Variable(x)).data(), b = m.forward(ag::Variable(x2)).data();
  EXPECT_EQ(max_abs_diff(a.narrow(1, 0, 4), b.narrow(1, 0, 4)), 0.0);
  EXPECT_GT(max_abs_diff(a.narrow(1, 4, 2), b.narrow(1, 4, 2)), 1e-3);
}

TEST(NnAttention, BadUseThrows) {
  Generator g(13);
  expect_error([&] { nn::MultiheadAttention({.dim = 10, .heads = 3}, g); },
               {"MultiheadAttention", "divisible", "dim 10"});
  expect_error([&] { nn::MultiheadAttention({.dim = 8, .heads = 2, .cross = true, .rope = true}, g); },
               {"MultiheadAttention", "self-attention only"});
  expect_error([&] { nn::MultiheadAttention({.dim = 6, .heads = 2, .rope = true}, g); },
               {"MultiheadAttention", "even"});
  nn::MultiheadAttention s({.dim = 8, .heads = 2}, g);
  nn::MultiheadAttention c({.dim = 8, .heads = 2, .cross = true, .ctx_dim = 5}, g);
  ag::Variable x(randn({1, 3, 8}, 1, DType::f32));
  expect_error([&] { s.forward(ag::Variable(randn({1, 3, 7}, 1, DType::f32))); }, {"MultiheadAttention", "[1, 3, 7]"});
  expect_error([&] { s.forward_cross(x, x); }, {"MultiheadAttention", "self-attention"});
  expect_error([&] { c.forward(x); }, {"MultiheadAttention", "cross-attention"});
  expect_error([&] { c.forward_cross(x, x); }, {"MultiheadAttention", "ctx", "[1, 3, 8]"});
  expect_error([&] { s.forward(x, Tensor::ones({1, 4})); }, {"key_mask", "[1, 4]"});
}

// ---------------------------------------------------------------------------------------------------------------
// adaLN

TEST(NnAdaLN, ModulateAndGatedResidualMatchNaiveAndGradcheck) {
  const int64_t B = 2, T = 3, D = 4;
  const Tensor x = randn({B, T, D}, 20), sh = randn({B, D}, 21), sc = randn({B, D}, 22), y = randn({B, T, D}, 23);
  Tensor m = nn::modulate(ag::Variable(x), ag::Variable(sh), ag::Variable(sc)).data();
  Tensor r = nn::gated_residual(ag::Variable(x), ag::Variable(sc), ag::Variable(y)).data();
  for (int64_t b = 0; b < B; ++b)
    for (int64_t t = 0; t < T; ++t)
      for (int64_t c = 0; c < D; ++c) {
        EXPECT_NEAR(m.at({b, t, c}), x.at({b, t, c}) * (1 + sc.at({b, c})) + sh.at({b, c}), 1e-15);
        EXPECT_NEAR(r.at({b, t, c}), x.at({b, t, c}) + sc.at({b, c}) * y.at({b, t, c}), 1e-15);
      }
  auto gm = ag::gradcheck([](const std::vector<ag::Variable>& a) { return nn::modulate(a[0], a[1], a[2]); },
                          {x, sh, sc});
  EXPECT_TRUE(gm.ok) << gm.message;
  auto gr = ag::gradcheck([](const std::vector<ag::Variable>& a) { return nn::gated_residual(a[0], a[1], a[2]); },
                          {x, sc, y});
  EXPECT_TRUE(gr.ok) << gr.message;
  // float32 path and a strided (transposed) x
  const Tensor xt = randn({B, D, T}, 24).transpose(1, 2);
  EXPECT_LT(max_abs_diff(nn::modulate(ag::Variable(xt.to(DType::f32)), ag::Variable(sh.to(DType::f32)),
                                      ag::Variable(sc.to(DType::f32))).data().to(DType::f64),
                         nn::modulate(ag::Variable(xt.contiguous()), ag::Variable(sh), ag::Variable(sc)).data()),
            1e-5);
}

TEST(NnAdaLN, ModuleChunksAreSiluLinear) {
  Generator g(25);
  nn::AdaLN ada(3, 4, 6, g);
  EXPECT_EQ(names_of(ada), (std::vector<std::string>{"weight[24, 3]", "bias[24]"}));
  ada.to(DType::f64);
  const Tensor c = randn({2, 3}, 26);
  auto chunks = ada.forward(ag::Variable(c));
  ASSERT_EQ(chunks.size(), 6u);
  for (int64_t k = 0; k < 6; ++k) {
    ASSERT_EQ(chunks[k].shape(), (Shape{2, 4}));
    for (int64_t b = 0; b < 2; ++b)
      for (int64_t j = 0; j < 4; ++j) {
        double acc = ada.bias.data().at({k * 4 + j});
        for (int64_t i = 0; i < 3; ++i) {
          const double ci = c.at({b, i});
          acc += ci / (1 + std::exp(-ci)) * ada.weight.data().at({k * 4 + j, i});
        }
        EXPECT_NEAR(chunks[k].data().at({b, j}), acc, 1e-14);
      }
  }
  ag::Variable cv(c, true);
  fd_check([&] {
    auto ch = ada.forward(cv);
    ag::Variable r = nn::gated_residual(ag::Variable(randn({2, 2, 4}, 27)), ch[2], ag::Variable(randn({2, 2, 4}, 28)));
    return nn::modulate(r, ch[0], ch[1]);
  }, params_and(ada, {cv}));
  ada.zero_init();
  for (auto& ch : ada.forward(cv)) EXPECT_EQ(t2m::sum(t2m::abs(ch.data())).item(), 0.0);
}

TEST(NnAdaLN, BadUseThrows) {
  ag::Variable x(randn({2, 3, 4}, 1)), bd(randn({2, 4}, 2));
  expect_error([&] { nn::modulate(x, ag::Variable(randn({2, 5}, 1)), bd); }, {"modulate", "(B, D)", "[2, 5]"});
  expect_error([&] { nn::modulate(ag::Variable(randn({3, 4}, 1)), bd, bd); }, {"modulate", "(B, T, D)"});
  expect_error([&] { nn::gated_residual(x, bd, ag::Variable(randn({2, 2, 4}, 1))); }, {"gated_residual", "[2, 2, 4]"});
  expect_error([&] { nn::modulate(x, ag::Variable(randn({2, 4}, 1, DType::f32)), bd); }, {"modulate", "dtype"});
  Generator g(1);
  nn::AdaLN ada(3, 4, 2, g);
  expect_error([&] { ada.forward(ag::Variable(randn({2, 5}, 1, DType::f32))); }, {"AdaLN", "[2, 5]"});
  expect_error([&] { nn::AdaLN(0, 4, 2, g); }, {"AdaLN"});
}
