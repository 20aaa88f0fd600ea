// test_text2bfm_generator.cpp — the flow-matching generator (models/text2bfm/generator.h): parameter names and
// counts of the anchor configs, float64 finite-difference check of every parameter and of the inputs on a tiny
// config, key-mask invariance (padding tokens change nothing), condition dropout / null condition, a tiny
// flow-loss overfit with AdamW, bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "autograd/no_grad.h"
#include "models/text2bfm/generator.h"
#include "models/text2bfm/timestep_embedding.h"
#include "nn/loss_flow.h"
#include "nn/optim_adamw.h"
#include "tensor/ops.h"
#include "tensor/parallel.h"
#include "tensor/rng.h"
#include "test_tensor_util.h"

using namespace t2m;
using t2m::testing::randn;
using namespace t2m::text2bfm;
using t2m::testing::expect_error;

namespace {

double max_diff(const Tensor& a, const Tensor& b) { return amax(abs(sub(a.to(DType::f64), b.to(DType::f64)))).item(); }

FlowGeneratorConfig tiny() {
  FlowGeneratorConfig c;
  c.latent = 3, c.width = 8, c.depth = 2, c.heads = 2, c.ctx_dim = 6, c.mlp_ratio = 2, c.freq_dim = 8;
  c.adapter = TextAdapterConfig{.tok_dim = 5, .width = 4, .depth = 1, .heads = 2, .ctx_dim = 6, .max_len = 6};
  return c;
}

// Every parameter to N(0, 0.5^2) in float64 so that no term (gates, norms, modulation) is trivially 0 or 1.
void randomise(nn::Module& m, uint64_t seed) {
  m.to(DType::f64);
  for (auto& p : m.parameters()) p.data().copy_(t2m::mul(randn(p.shape(), seed++), 0.5));
}

// Central differences of L = sum(f() * W) against backward() for every element of every tensor in wrt.
void fd_check(const std::function<ag::Variable()>& f, const std::vector<ag::Variable>& wrt, double tol = 1e-6) {
  for (const auto& v : wrt) v.clear_grad();
  ag::Variable y = f();
  const Tensor w = randn(y.shape(), 4321);
  y.backward(w);
  auto loss = [&] {
    ag::NoGradGuard ng;
    return t2m::sum(t2m::mul(f().data(), w)).item();
  };
  for (size_t i = 0; i < wrt.size(); ++i) {
    ASSERT_TRUE(wrt[i].grad().defined()) << "no gradient for tensor " << i << " " << wrt[i].name();
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
      ASSERT_NEAR(g.data<double>()[j], num, tol * (1 + std::abs(num)))
          << "tensor " << i << " (" << wrt[i].name() << ") element " << j;
    }
  }
}

}  // namespace

TEST(FlowGenerator, ParameterNamesAndCountsFollowTheAnchor) {
  Generator g(1);
  FlowGenerator small(FlowGeneratorConfig::small(), g);
  // torch_ref.py FM_CONFIGS["small"]: 7.15M parameters; ours adds null_ctx (ctx_dim).
  int64_t n = 0;
  std::vector<std::string> names;
  for (auto& [name, v] : small.named_parameters()) names.push_back(name), n += v.numel();
  // own parameters first, then children in registration order (torch's named_parameters order): null_ctx, then
  // exactly the anchor's sequence
  EXPECT_EQ(names[0], "null_ctx");
  EXPECT_EQ(names[1], "x_in.weight");
  EXPECT_EQ(names[3], "t_mlp.0.weight");
  EXPECT_EQ(names[5], "t_mlp.2.weight");
  EXPECT_EQ(names[7], "text.pos");
  EXPECT_EQ(names[8], "text.inp.weight");
  EXPECT_EQ(names[10], "text.blocks.0.n1.weight");
  EXPECT_EQ(names[names.size() - 4], "f_ada.weight");
  EXPECT_EQ(names[names.size() - 2], "f_out.weight");
  EXPECT_EQ(names.size(), 117u + 1u);  // torch: 117 tensors
  EXPECT_EQ(n, 7150384 + 256);         // torch: 7,150,384 (printed by the anchor) + null_ctx
  // fm-paper: tok_dim == adapter width, so no text.inp (torch's nn.Identity); torch: 66,412,848 + null_ctx.
  Generator g2(2);
  FlowGenerator paper(FlowGeneratorConfig::paper(), g2);
  EXPECT_EQ(paper.num_parameters(), 66412848 + 1024);
  for (auto& [name, v] : paper.named_parameters()) EXPECT_NE(name.rfind("text.inp", 0), 0u) << name;
  expect_error([] { FlowGeneratorConfig::by_name("fm-huge"); }, {"fm-huge", "fm-small"});
}

TEST(FlowGenerator, TimestepEmbeddingValues) {
  const Tensor t = Tensor::from_vector(std::vector<double>{0.0, 0.25}, {2});
  const Tensor e = timestep_embedding(t, 4);
  // f = [1, 1e-2]; args 1000 t f
  EXPECT_DOUBLE_EQ(e.at({0, 0}), 1.0);
  EXPECT_DOUBLE_EQ(e.at({0, 2}), 0.0);
  EXPECT_NEAR(e.at({1, 0}), std::cos(250.0), 1e-12);
  EXPECT_NEAR(e.at({1, 1}), std::cos(2.5), 1e-12);
  EXPECT_NEAR(e.at({1, 3}), std::sin(2.5), 1e-12);
  expect_error([&] { timestep_embedding(t, 3); }, {"timestep_embedding", "even"});
  expect_error([&] { timestep_embedding(t.view({1, 2}), 4); }, {"1-D", "[1, 2]"});
}

TEST(FlowGenerator, Float64GradcheckOfEveryParameterAndInput) {
  Generator g(3);
  FlowGenerator gen(tiny(), g);
  randomise(gen, 100);
  ag::Variable m(randn({2, 3, 3}, 5), true), tok(randn({2, 4, 5}, 6), true);
  const Tensor t = Tensor::from_vector(std::vector<double>{0.3, 0.8}, {2});
  Tensor tm = Tensor::ones({2, 4}, DType::f64), mm = Tensor::ones({2, 3}, DType::f64);
  tm.set({1, 3}, 0.0), mm.set({0, 2}, 0.0);
  const Tensor drop = Tensor::from_vector(std::vector<double>{0.0, 1.0}, {2});
  std::vector<ag::Variable> wrt = gen.parameters();
  wrt.push_back(m), wrt.push_back(tok);
  // sample 1 is dropped: null_ctx gets a gradient, the text path gets it from sample 0
  fd_check([&] { return gen.forward(m, t, tok, tm, drop, mm); }, wrt);
}

TEST(FlowGenerator, PaddingTokensChangeNothing) {
  Generator g(4);
  FlowGenerator gen(tiny(), g);
  const Tensor m = randn({2, 3, 3}, 7, DType::f32), t = Tensor::from_vector(std::vector<float>{0.1f, 0.6f}, {2});
  Tensor tok = randn({2, 5, 5}, 8, DType::f32);
  Tensor mask = Tensor::ones({2, 5});
  mask.set({0, 3}, 0.0), mask.set({0, 4}, 0.0), mask.set({1, 4}, 0.0);
  const Tensor a = gen.forward(ag::Variable(m), t, ag::Variable(tok), mask).data();
  Tensor tok2 = tok.clone();
  for (int64_t j = 0; j < 5; ++j) tok2.set({0, 3, j}, 50.0), tok2.set({0, 4, j}, -7.0), tok2.set({1, 4, j}, 3.0);
  const Tensor b = gen.forward(ag::Variable(m), t, ag::Variable(tok2), mask).data();
  EXPECT_EQ(max_diff(a, b), 0.0);  // masked keys get probability exactly 0
  // and equal to running each sample with only its real tokens
  for (int64_t s = 0; s < 2; ++s) {
    const int64_t L = s == 0 ? 3 : 4;
    const Tensor one = gen.forward(ag::Variable(m.narrow(0, s, 1)), t.narrow(0, s, 1),
                                   ag::Variable(tok.narrow(0, s, 1).narrow(1, 0, L).contiguous()))
                           .data();
    EXPECT_LT(max_diff(one, a.narrow(0, s, 1)), 2e-5) << "sample " << s;
  }
  // without the mask the padding does matter
  const Tensor u = gen.forward(ag::Variable(m), t, ag::Variable(tok2)).data();
  EXPECT_GT(max_diff(a, u), 1e-3);
}

TEST(FlowGenerator, ConditionDropoutUsesTheNullContext) {
  Generator g(5);
  FlowGenerator gen(tiny(), g);
  const Tensor m = randn({3, 2, 3}, 9, DType::f32), t = Tensor::from_vector(std::vector<float>{0.2f, 0.5f, 0.9f}, {3});
  const Tensor tok = randn({3, 4, 5}, 10, DType::f32);
  Tensor mask = Tensor::ones({3, 4});
  mask.set({1, 0}, 0.0), mask.set({1, 1}, 0.0), mask.set({1, 2}, 0.0);
  const Tensor drop = Tensor::from_vector(std::vector<float>{0.f, 1.f, 0.f}, {3});
  const Tensor a = gen.forward(ag::Variable(m), t, ag::Variable(tok), mask, drop).data();
  const Tensor nc = gen.forward(ag::Variable(m), t, ag::Variable(tok), mask).data();
  const Tensor nul = gen.velocity(ag::Variable(m), t, gen.null_context(3)).data();
  EXPECT_EQ(max_diff(a.narrow(0, 0, 1), nc.narrow(0, 0, 1)), 0.0);  // kept rows: unchanged
  EXPECT_EQ(max_diff(a.narrow(0, 2, 1), nc.narrow(0, 2, 1)), 0.0);
  EXPECT_LT(max_diff(a.narrow(0, 1, 1), nul.narrow(0, 1, 1)), 1e-6);  // dropped row: the null condition
  EXPECT_GT(max_diff(a.narrow(0, 1, 1), nc.narrow(0, 1, 1)), 1e-4);
  // the drop draw: deterministic, about cond_dropout = 0.2 of 4000
  Generator r1(42), r2(42);
  const Tensor d1 = gen.sample_condition_drop(4000, r1), d2 = gen.sample_condition_drop(4000, r2);
  EXPECT_EQ(max_diff(d1, d2), 0.0);
  EXPECT_NEAR(sum(d1).item() / 4000.0, 0.2, 0.02);
}

TEST(FlowGenerator, FlowLossOverfitsATinyBatch) {
  set_num_threads(1);
  Generator g(6);
  FlowGeneratorConfig cf = tiny();
  cf.width = 16, cf.heads = 2;
  FlowGenerator gen(cf, g);
  Generator data(7);
  const Tensor x1 = rand_normal({4, 4, 3}, data), x0 = rand_normal({4, 4, 3}, data);
  const Tensor t = rand_uniform({4}, data), tok = rand_normal({4, 3, 5}, data);
  const nn::FlowPoint fp = nn::flow_interpolate(ag::Variable(x0), ag::Variable(x1), ag::Variable(t));
  nn::AdamWOptions ao;
  ao.lr = 3e-3, ao.weight_decay = 0.0;
  nn::AdamW opt(gen.named_parameters(), ao);
  double first = 0, last = 0;
  for (int step = 0; step < 300; ++step) {
    opt.zero_grad();
    ag::Variable loss = nn::flow_matching_loss(gen.forward(fp.x_t, t, ag::Variable(tok)), ag::Variable(x0),
                                               ag::Variable(x1));
    loss.backward();
    opt.step();
    if (step == 0) first = loss.item();
    last = loss.item();
  }
  EXPECT_GT(first, 0.5);
  EXPECT_LT(last, 0.02 * first) << "first " << first << " last " << last;
}

TEST(FlowGenerator, BadInputThrows) {
  Generator g(8);
  FlowGenerator gen(tiny(), g);
  const Tensor t = Tensor::zeros({2});
  ag::Variable m(Tensor::zeros({2, 3, 3})), tok(Tensor::zeros({2, 4, 5}));
  expect_error([&] { gen.forward(ag::Variable(Tensor::zeros({2, 3, 4})), t, tok); }, {"FlowGenerator", "[2, 3, 4]"});
  expect_error([&] { gen.forward(m, Tensor::zeros({3}), tok); }, {"t must be (B)", "[3]"});
  expect_error([&] { gen.forward(m, t, ag::Variable(Tensor::zeros({2, 4, 6}))); }, {"TextAdapter", "[2, 4, 6]"});
  expect_error([&] { gen.forward(m, t, ag::Variable(Tensor::zeros({2, 7, 5}))); }, {"L <= 6"});
  expect_error([&] { gen.forward(m, t, ag::Variable(Tensor::zeros({3, 4, 5}))); }, {"share B"});
  expect_error([&] { gen.forward(m, t, tok, Tensor(), Tensor::zeros({3})); }, {"drop must be (B)"});
  expect_error([&] { gen.forward(m, t, tok, Tensor(), Tensor(), Tensor::ones({2, 2})); }, {"m_mask"});
  expect_error([&] { gen.forward(m, t, tok, Tensor::ones({2, 3})); }, {"key_mask"});
  FlowGeneratorConfig bad = tiny();
  bad.adapter.ctx_dim = 7;
  expect_error([&] { FlowGenerator(bad, g); }, {"bad config", "adapter ctx_dim 7"});
  bad = tiny();
  bad.cond_dropout = 1.5;
  expect_error([&] { FlowGenerator(bad, g); }, {"cond_dropout"});
}
