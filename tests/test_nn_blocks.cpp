// test_nn_blocks.cpp — DiTBlock and TransformerBlock: parameter names/order/shapes exactly as torch_ref.py's
// DiTBlock/EncBlock (so PyTorch weights load by name), values against a reference written line by line from the
// PyTorch forward with elementary autograd ops (LayerNorm, modulate, chunk order, gates, tanh-GELU written out),
// float64 finite-difference checks of inputs and every parameter, padding masks, bad use.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "autograd/no_grad.h"
#include "autograd/ops_elementwise.h"
#include "autograd/ops_join.h"
#include "autograd/ops_linalg.h"
#include "autograd/ops_mha.h"
#include "autograd/ops_reduce.h"
#include "autograd/ops_shape.h"
#include "autograd/ops_unary.h"
#include "nn/dit_block.h"
#include "nn/transformer_block.h"
#include "tensor/ops.h"
#include "tensor/rng.h"
#include "test_tensor_util.h"

using namespace t2m;
using t2m::testing::randn;
using t2m::testing::expect_error;

namespace {

std::vector<std::string> names_of(const nn::Module& m) {
  std::vector<std::string> r;
  for (auto& kv : m.named_parameters()) r.push_back(kv.first + shape_str(kv.second.shape()));
  return r;
}

ag::Variable P(const nn::Module& m, const std::string& name) {
  for (auto& [n, v] : m.named_parameters())
    if (n == name) return v;
  ADD_FAILURE() << "no parameter " << name;
  return ag::Variable();
}

// Module parameters get random values (norm weights/biases and adaLN included) so that no term is trivial.
void randomise(nn::Module& m, uint64_t seed) {
  m.to(DType::f64);
  for (auto& p : m.parameters()) p.data().copy_(t2m::mul(randn(p.shape(), seed++), 0.5));
}

ag::Variable lin(const ag::Variable& x, const nn::Module& m, const std::string& pre, bool bias = true) {
  ag::Variable y = ag::matmul(x, ag::transpose(P(m, pre + ".weight"), 0, 1));
  return bias ? y + P(m, pre + ".bias") : y;
}

ag::Variable ln(const ag::Variable& x, double eps) {  // LayerNorm without affine, biased variance
  ag::Variable c = x - ag::mean(x, {-1}, true);
  return c / ag::sqrt(ag::mean(c * c, {-1}, true) + eps);
}

ag::Variable gelu(const ag::Variable& x) {  // 0.5 x (1 + tanh(sqrt(2/pi)(x + 0.044715 x^3)))
  return 0.5 * x * (1.0 + ag::tanh(std::sqrt(2.0 / M_PI) * (x + 0.044715 * x * x * x)));
}

ag::Variable mlp(const ag::Variable& x, const nn::Module& m, const std::string& pre) {
  return lin(gelu(lin(x, m, pre + ".fc1")), m, pre + ".fc2");
}

ag::Variable bcast(const ag::Variable& v) { return ag::unsqueeze(v, 1); }  // (B, D) -> (B, 1, D)

// torch_ref.py DiTBlock.forward, line by line.
ag::Variable ref_dit(const nn::DiTBlock& blk, const ag::Variable& x0, const ag::Variable& c, const ag::Variable& ctx,
                     const Tensor& ctx_mask, int64_t pos0) {
  const auto& cf = blk.config();
  auto ch = ag::chunk(lin(c * ag::sigmoid(c), blk, "ada"), 6, -1);  // sh1, sc1, g1, sh2, sc2, g2
  ag::MhaOptions so;
  so.heads = cf.heads, so.rope = true, so.rope_pos0 = pos0;
  ag::MhaOptions co;
  co.heads = cf.heads;
  ag::Variable h = ln(x0, 1e-6) * (1.0 + bcast(ch[1])) + bcast(ch[0]);
  ag::Variable a = lin(ag::mha_self(lin(h, blk, "attn.qkv"), P(blk, "attn.qn.weight"), P(blk, "attn.kn.weight"),
                                    Tensor(), so), blk, "attn.proj");
  ag::Variable x = x0 + bcast(ch[2]) * a;
  ag::Variable n2 = ln(x, 1e-6) * P(blk, "n2.weight") + P(blk, "n2.bias");
  x = x + lin(ag::mha_cross(lin(n2, blk, "xattn.q"), lin(ctx, blk, "xattn.kv"), P(blk, "xattn.qn.weight"),
                            P(blk, "xattn.kn.weight"), ctx_mask, co), blk, "xattn.proj");
  ag::Variable h3 = ln(x, 1e-6) * (1.0 + bcast(ch[4])) + bcast(ch[3]);
  return x + bcast(ch[5]) * mlp(h3, blk, "mlp");
}

// torch_ref.py EncBlock.forward.
ag::Variable ref_enc(const nn::TransformerBlock& blk, const ag::Variable& x0, const Tensor& mask) {
  ag::MhaOptions o;
  o.heads = blk.config().heads;
  auto n = [&](const ag::Variable& v, const std::string& p) {
    return ln(v, 1e-5) * P(blk, p + ".weight") + P(blk, p + ".bias");
  };
  ag::Variable x = x0 + lin(ag::mha_self(lin(n(x0, "n1"), blk, "attn.qkv"), {}, {}, mask, o), blk, "attn.proj");
  return x + mlp(n(x, "n2"), blk, "mlp");
}

// Central differences of L = sum(f() * W) against backward() for every element of every tensor in wrt.
void fd_check(const std::function<ag::Variable()>& f, const std::vector<ag::Variable>& wrt, double tol = 1e-6) {
  for (const auto& v : wrt) v.clear_grad();
  ag::Variable y = f();
  const Tensor w = randn(y.shape(), 4321);
  y.backward(w);
  auto loss = [&] { return t2m::sum(t2m::mul(f().data(), w)).item(); };
  for (size_t i = 0; i < wrt.size(); ++i) {
    ASSERT_TRUE(wrt[i].grad().defined()) << "no gradient for " << wrt[i].name();
    const Tensor g = wrt[i].grad().contiguous();
    double* p = wrt[i].data().data<double>();
    for (int64_t j = 0; j < wrt[i].numel(); ++j) {
      const double old = p[j], eps = 1e-6;
      p[j] = old + eps;
      const double lp = loss();
      p[j] = old - eps;
      const double lm = loss();
      p[j] = old;
      const double num = (lp - lm) / (2 * eps);
      ASSERT_NEAR(g.data<double>()[j], num, tol * (1 + std::abs(num))) << "tensor " << i << " element " << j;
    }
  }
}

std::vector<ag::Variable> params_and(const nn::Module& m, const std::vector<ag::Variable>& extra) {
  std::vector<ag::Variable> r = m.parameters();
  r.insert(r.end(), extra.begin(), extra.end());
  return r;
}

}  // namespace

TEST(NnDiTBlock, ParameterNamesFollowTorchRef) {
  Generator g(1);
  nn::DiTBlock b({.dim = 8, .heads = 2, .ctx_dim = 6}, g);
  EXPECT_EQ(names_of(b), (std::vector<std::string>{
                             "attn.qkv.weight[24, 8]", "attn.qkv.bias[24]", "attn.qn.weight[4]", "attn.kn.weight[4]",
                             "attn.proj.weight[8, 8]", "attn.proj.bias[8]", "n2.weight[8]", "n2.bias[8]",
                             "xattn.q.weight[8, 8]", "xattn.q.bias[8]", "xattn.kv.weight[16, 6]", "xattn.kv.bias[16]",
                             "xattn.qn.weight[4]", "xattn.kn.weight[4]", "xattn.proj.weight[8, 8]",
                             "xattn.proj.bias[8]", "mlp.fc1.weight[32, 8]", "mlp.fc1.bias[32]",
                             "mlp.fc2.weight[8, 32]", "mlp.fc2.bias[8]", "ada.weight[48, 8]", "ada.bias[48]"}));
  // fm-small block size: width 256, ctx 256 -> 12 D^2 + attn/xattn/mlp/ada terms
  Generator g2(2);
  nn::DiTBlock small({.dim = 256, .heads = 4, .ctx_dim = 256}, g2);
  const int64_t D = 256;
  EXPECT_EQ(small.num_parameters(), (3 * D * D + 3 * D) + 2 * 64 + (D * D + D) + 2 * D + (D * D + D) +
                                        (2 * D * D + 2 * D) + 2 * 64 + (D * D + D) + (4 * D * D + 4 * D) +
                                        (4 * D * D + D) + (6 * D * D + 6 * D));
}

TEST(NnDiTBlock, MatchesTorchRefForwardAndGradients) {
  Generator g(3);
  nn::DiTBlock blk({.dim = 4, .heads = 2, .ctx_dim = 3, .mlp_ratio = 2}, g);
  randomise(blk, 10);
  ag::Variable x(randn({2, 3, 4}, 4), true), c(randn({2, 4}, 5), true), ctx(randn({2, 5, 3}, 6), true);
  Tensor cm = Tensor::ones({2, 5}, DType::f64);
  cm.set({1, 3}, 0.0), cm.set({1, 4}, 0.0);
  for (int64_t pos0 : {0, 2}) {
    Tensor y = blk.forward(x, c, ctx, Tensor(), cm, pos0).data();
    EXPECT_EQ(y.shape(), (Shape{2, 3, 4}));
    EXPECT_LT(max_abs_diff(y, ref_dit(blk, x, c, ctx, cm, pos0).data()), 1e-12);
  }
  fd_check([&] { return blk.forward(x, c, ctx, Tensor(), cm, 1); }, params_and(blk, {x, c, ctx}));
}

TEST(NnDiTBlock, MasksHideKeys) {
  Generator g(7);
  nn::DiTBlock blk({.dim = 8, .heads = 2, .ctx_dim = 4}, g);
  const Tensor x = randn({1, 4, 8}, 8, DType::f32), c = randn({1, 8}, 9, DType::f32);
  const Tensor ctx = randn({1, 3, 4}, 10, DType::f32);
  Tensor xm = Tensor::ones({1, 4}), cm = Tensor::ones({1, 3});
  xm.set({0, 3}, 0.0), cm.set({0, 2}, 0.0);
  Tensor x2 = x.clone(), ctx2 = ctx.clone();
  for (int64_t j = 0; j < 8; ++j) x2.set({0, 3, j}, 5.0);
  for (int64_t j = 0; j < 4; ++j) ctx2.set({0, 2, j}, -5.0);
  Tensor a = blk.forward(ag::Variable(x), ag::Variable(c), ag::Variable(ctx), xm, cm).data();
  Tensor b = blk.forward(ag::Variable(x2), ag::Variable(c), ag::Variable(ctx2), xm, cm).data();
  EXPECT_LT(max_abs_diff(a.narrow(1, 0, 3), b.narrow(1, 0, 3)), 1e-6);  // rows 0..2 never see row 3 or ctx 2
  Tensor u = blk.forward(ag::Variable(x2), ag::Variable(c), ag::Variable(ctx2)).data();
  EXPECT_GT(max_abs_diff(a.narrow(1, 0, 3), u.narrow(1, 0, 3)), 1e-3);   // without masks they would
}

TEST(NnDiTBlock, BadUseThrows) {
  Generator g(11);
  nn::DiTBlock blk({.dim = 8, .heads = 2, .ctx_dim = 4}, g);
  ag::Variable x(randn({2, 3, 8}, 1, DType::f32)), ctx(randn({2, 5, 4}, 2, DType::f32));
  expect_error([&] { blk.forward(x, ag::Variable(randn({2, 7}, 3, DType::f32)), ctx); }, {"DiTBlock", "[2, 7]"});
  expect_error([&] { blk.forward(x, ag::Variable(randn({2, 8}, 3, DType::f32)), x); }, {"ctx", "[2, 3, 8]"});
  expect_error([&] { nn::DiTBlock({.dim = 8, .heads = 3}, g); }, {"divisible"});
}

TEST(NnTransformerBlock, NamesValuesGradientsAndPadding) {
  Generator g(12);
  nn::TransformerBlock blk({.dim = 4, .heads = 2, .mlp_ratio = 2}, g);
  EXPECT_EQ(names_of(blk), (std::vector<std::string>{"n1.weight[4]", "n1.bias[4]", "attn.qkv.weight[12, 4]",
                                                     "attn.qkv.bias[12]", "attn.proj.weight[4, 4]", "attn.proj.bias[4]",
                                                     "n2.weight[4]", "n2.bias[4]", "mlp.fc1.weight[8, 4]",
                                                     "mlp.fc1.bias[8]", "mlp.fc2.weight[4, 8]", "mlp.fc2.bias[4]"}));
  randomise(blk, 20);
  ag::Variable x(randn({2, 5, 4}, 13), true);
  Tensor m = Tensor::ones({2, 5}, DType::f64);
  m.set({0, 4}, 0.0), m.set({1, 2}, 0.0);
  EXPECT_LT(max_abs_diff(blk.forward(x, m).data(), ref_enc(blk, x, m).data()), 1e-12);
  EXPECT_LT(max_abs_diff(blk.forward(x).data(), ref_enc(blk, x, Tensor()).data()), 1e-12);
  fd_check([&] { return blk.forward(x, m); }, params_and(blk, {x}));
  // a padded token does not change the real tokens' outputs
  Tensor x2 = x.data().clone();
  for (int64_t j = 0; j < 4; ++j) x2.set({1, 2, j}, 30.0);
  Tensor a = blk.forward(x, m).data(), b = blk.forward(ag::Variable(x2), m).data();
  for (int64_t t : {0, 1, 3, 4}) EXPECT_LT(max_abs_diff(a.narrow(1, t, 1), b.narrow(1, t, 1)), 1e-12) << t;
  expect_error([&] { blk.forward(ag::Variable(randn({2, 5, 3}, 1))); }, {"[2, 5, 3]"});
}

TEST(NnDiTBlock, Float32AgreesWithFloat64) {
  // the same weights in float32 and float64: outputs and parameter gradients agree to float precision (the
  // PyTorch parity target is 1e-4 relative in float32)
  Generator g1(30), g2(30);
  nn::DiTBlock b32({.dim = 16, .heads = 4, .ctx_dim = 8}, g1), b64({.dim = 16, .heads = 4, .ctx_dim = 8}, g2);
  b64.to(DType::f64);
  const Tensor x = randn({2, 6, 16}, 31), c = randn({2, 16}, 32), ctx = randn({2, 5, 8}, 33), w = randn({2, 6, 16}, 34);
  ag::Variable y32 = b32.forward(ag::Variable(x.to(DType::f32)), ag::Variable(c.to(DType::f32)),
                                 ag::Variable(ctx.to(DType::f32)), Tensor(), Tensor(), 3);
  ag::Variable y64 = b64.forward(ag::Variable(x), ag::Variable(c), ag::Variable(ctx), Tensor(), Tensor(), 3);
  const double scale = t2m::amax(t2m::abs(y64.data())).item();
  EXPECT_LT(max_abs_diff(y32.data().to(DType::f64), y64.data()), 1e-5 * scale);
  y32.backward(w.to(DType::f32));
  y64.backward(w);
  const auto p32 = b32.named_parameters(), p64 = b64.named_parameters();
  for (size_t i = 0; i < p32.size(); ++i) {
    const Tensor& g64 = p64[i].second.grad();
    const double gs = t2m::amax(t2m::abs(g64)).item();
    EXPECT_LT(max_abs_diff(p32[i].second.grad().to(DType::f64), g64), 1e-4 * gs + 1e-6) << p32[i].first;
  }
}

TEST(NnDiTBlock, InferenceUnderNoGradRecordsNothing) {
  Generator g(40);
  nn::DiTBlock blk({.dim = 8, .heads = 2, .ctx_dim = 4}, g);
  const Tensor x = randn({2, 3, 8}, 41, DType::f32), c = randn({2, 8}, 42, DType::f32);
  const Tensor ctx = randn({2, 5, 4}, 43, DType::f32);
  ag::Variable with = blk.forward(ag::Variable(x), ag::Variable(c), ag::Variable(ctx));
  EXPECT_TRUE(with.grad_fn() != nullptr);  // the parameters require grad
  ag::NoGradGuard guard;
  ag::Variable without = blk.forward(ag::Variable(x), ag::Variable(c), ag::Variable(ctx));
  EXPECT_TRUE(without.grad_fn() == nullptr);
  EXPECT_FALSE(without.requires_grad());
  EXPECT_EQ(max_abs_diff(with.data(), without.data()), 0.0);
}
