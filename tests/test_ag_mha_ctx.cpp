// test_ag_mha_ctx.cpp — cross-attention with the value projection after the weighted sum (autograd/ops_mha_ctx.h,
// tensor/fused/attention_ctx.h): values and the gradients of all six inputs against mha_cross over the kv Linear
// (the form it replaces), with and without QK-norm, bias and key mask (a batch row with no visible key included),
// on the per-head dot/axpy loops (d = 3), the register-blocked ones (d = 32, float64 and float32) and the baseline
// ISA build; float64 finite-difference gradchecks; the module takes it by the cost rule and gives the same training
// gradients either way; bad use throws.
#include <gtest/gtest.h>

#include <functional>

#include "autograd/gradcheck.h"
#include "autograd/ops_mha.h"
#include "autograd/ops_mha_ctx.h"
#include "autograd/ops_reduce.h"
#include "autograd/ops_unary.h"
#include "nn/attention.h"
#include "nn/linear.h"
#include "tensor/cpu_features.h"
#include "tensor/ops.h"
#include "tensor/rng.h"
#include "test_tensor_util.h"

using namespace t2m;
using t2m::testing::randn;
using t2m::testing::expect_error;

namespace {

// Batch b hides its last b keys; with `empty_row`, batch row 1 hides every key.
Tensor mask_of(int64_t B, int64_t Tk, bool empty_row) {
  Tensor m = Tensor::ones({B, Tk}, DType::f64);
  for (int64_t b = 0; b < B; ++b)
    for (int64_t j = std::max<int64_t>(1, Tk - b); j < Tk; ++j) m.set({b, j}, 0.0);
  if (empty_row && B > 1)
    for (int64_t j = 0; j < Tk; ++j) m.set({1, j}, 0.0);
  return m;
}

struct Case {
  int64_t B, Tq, Tk, H, d, C;
  bool norm, bias, mask, empty_row;
};

using Fn = std::function<ag::Variable(const std::vector<ag::Variable>&)>;

// Inputs: q (B,Tq,D), ctx (B,Tk,C), kv weight (2D,C), [kv bias (2D)], [q_norm, k_norm (d)].
std::vector<Tensor> inputs_of(const Case& c, DType dt, uint64_t seed) {
  const int64_t D = c.H * c.d;
  std::vector<Tensor> in{randn({c.B, c.Tq, D}, seed, dt), randn({c.B, c.Tk, c.C}, seed + 1, dt),
                         t2m::mul(randn({2 * D, c.C}, seed + 2, dt), 0.3)};
  if (c.bias) in.push_back(randn({2 * D}, seed + 3, dt));
  if (c.norm) in.push_back(t2m::add(randn({c.d}, seed + 4, dt), 1.0)), in.push_back(randn({c.d}, seed + 5, dt));
  return in;
}

// The op under test and the form it replaces, on the same inputs.
std::pair<Fn, Fn> both_forms(const Case& c, const Tensor& mask) {
  ag::MhaOptions o;
  o.heads = c.H;
  auto parts = [c](const std::vector<ag::Variable>& x) {
    const size_t n = c.bias ? 4 : 3;
    return std::make_tuple(c.bias ? x[3] : ag::Variable(), c.norm ? x[n] : ag::Variable(),
                           c.norm ? x[n + 1] : ag::Variable());
  };
  Fn ctx_form = [=](const std::vector<ag::Variable>& x) {
    auto [b, qn, kn] = parts(x);
    return ag::mha_cross_ctx(x[0], x[1], x[2], b, qn, kn, mask, o);
  };
  Fn kv_form = [=](const std::vector<ag::Variable>& x) {
    auto [b, qn, kn] = parts(x);
    return ag::mha_cross(x[0], nn::linear(x[1], x[2], b), qn, kn, mask, o);
  };
  return {ctx_form, kv_form};
}

// Outputs and every input's gradient under one random output weighting, relative to the largest reference value.
void expect_same(const Fn& a_fn, const Fn& b_fn, const std::vector<Tensor>& in, double rtol) {
  std::vector<ag::Variable> a, b;
  for (const Tensor& t : in) a.emplace_back(t.clone(), true), b.emplace_back(t.clone(), true);
  ag::Variable ya = a_fn(a), yb = b_fn(b);
  ASSERT_EQ(ya.shape(), yb.shape());
  auto scale = [](const Tensor& t) { return std::max(1.0, t2m::amax(t2m::abs(t.to(DType::f64))).item()); };
  EXPECT_LT(max_abs_diff(ya.data().to(DType::f64), yb.data().to(DType::f64)), rtol * scale(yb.data()));
  const Tensor w = randn(ya.shape(), 99, ya.dtype());
  ya.backward(w);
  yb.backward(w);
  for (size_t i = 0; i < in.size(); ++i) {
    ASSERT_TRUE(a[i].grad().defined()) << "input " << i;
    EXPECT_LT(max_abs_diff(a[i].grad().to(DType::f64), b[i].grad().to(DType::f64)), rtol * scale(b[i].grad()))
        << "input " << i;
  }
}

}  // namespace

TEST(AgMhaCtx, MatchesCrossAttentionOverTheKvLinearFloat64) {
  // d = 3: the dot/axpy loops; d = 32: the register-blocked ones. C = 7 and 40: column tails of every width.
  for (const Case& c : {Case{2, 3, 5, 2, 3, 7, false, false, false, false},
                        Case{2, 3, 5, 2, 3, 7, true, true, true, true},
                        Case{3, 4, 6, 2, 32, 40, true, true, true, false},
                        Case{2, 5, 3, 3, 32, 9, false, true, false, false}}) {
    SCOPED_TRACE("d " + std::to_string(c.d) + " C " + std::to_string(c.C) + " norm " + std::to_string(c.norm) +
                 " bias " + std::to_string(c.bias) + " mask " + std::to_string(c.mask));
    const Tensor mask = c.mask ? mask_of(c.B, c.Tk, c.empty_row) : Tensor();
    auto [ctx_form, kv_form] = both_forms(c, mask);
    expect_same(ctx_form, kv_form, inputs_of(c, DType::f64, 10), 1e-12);
  }
}

TEST(AgMhaCtx, FloatAndBaselineIsaAgree) {
  // The fm generator's head shape (d = 64, 24 keys, 8 queries) in float32 on the build the CPU picks and on the
  // baseline (AVX2) build: both close to the kv form.
  const Case c{3, 8, 24, 4, 64, 96, true, true, true, false};
  const Tensor mask = mask_of(c.B, c.Tk, false);
  auto [ctx_form, kv_form] = both_forms(c, mask);
  for (bool baseline : {false, true}) {
    SCOPED_TRACE(baseline ? "baseline ISA" : "CPU's ISA");
    force_baseline_isa(baseline);
    expect_same(ctx_form, kv_form, inputs_of(c, DType::f32, 20), 2e-5);
  }
  force_baseline_isa(false);
}

TEST(AgMhaCtx, Gradcheck) {
  for (const Case& c :
       {Case{2, 2, 3, 2, 2, 5, true, true, true, false}, Case{1, 3, 2, 1, 3, 4, false, false, false, false}}) {
    const Tensor mask = c.mask ? mask_of(c.B, c.Tk, false) : Tensor();
    auto [ctx_form, kv_form] = both_forms(c, mask);
    ag::GradcheckResult r = ag::gradcheck(ctx_form, inputs_of(c, DType::f64, 30));
    EXPECT_TRUE(r.ok) << r.message;
  }
}

TEST(AgMhaCtx, CostRuleAndModuleChoice) {
  // fm-paper: 8 heads of 64 over 24 tokens of width 1024; taken at 8 motion tokens, not at 16.
  EXPECT_TRUE(ag::mha_cross_ctx_chosen(8, 24, 1024, 8, 64));
  EXPECT_FALSE(ag::mha_cross_ctx_chosen(16, 24, 1024, 8, 64));
  EXPECT_FALSE(ag::mha_cross_ctx_chosen(8, 24, 64, 8, 8));  // a narrow context: projecting it is cheap
  ag::mha_cross_ctx_force("never");
  EXPECT_FALSE(ag::mha_cross_ctx_chosen(8, 24, 1024, 8, 64));
  ag::mha_cross_ctx_force("always");
  EXPECT_TRUE(ag::mha_cross_ctx_chosen(16, 24, 1024, 8, 64));
  ag::mha_cross_ctx_force("auto");
  expect_error([] { ag::mha_cross_ctx_force("sometimes"); }, {"mha_cross_ctx_force", "sometimes"});

  // The module gives the same outputs and parameter gradients whichever form it takes (float32).
  Generator gen(5);
  nn::AttentionConfig cfg;
  cfg.dim = 64, cfg.heads = 4, cfg.cross = true, cfg.ctx_dim = 48, cfg.qk_norm = true;
  nn::MultiheadAttention attn(cfg, gen);
  const ag::Variable x(randn({2, 8, 64}, 40, DType::f32)), ctx(randn({2, 24, 48}, 41, DType::f32));
  const Tensor mask = mask_of(2, 24, false).to(DType::f32);
  std::vector<Tensor> out, grads;
  for (const char* mode : {"always", "never"}) {
    ag::mha_cross_ctx_force(mode);
    for (auto& [name, p] : attn.named_parameters()) p.zero_grad();
    ag::Variable y = attn.forward_cross(x, ctx, mask);
    ag::sum(ag::square(y)).backward();
    out.push_back(y.data());
    for (auto& [name, p] : attn.named_parameters()) grads.push_back(p.grad().clone());
  }
  ag::mha_cross_ctx_force("auto");
  EXPECT_LT(max_abs_diff(out[0], out[1]), 1e-5);
  const size_t n = grads.size() / 2;
  for (size_t i = 0; i < n; ++i) {
    const double s = std::max(1.0, t2m::amax(t2m::abs(grads[n + i])).item());
    EXPECT_LT(max_abs_diff(grads[i], grads[n + i]), 1e-4 * s) << "parameter " << i;
  }
}

TEST(AgMhaCtx, BadUseThrows) {
  ag::MhaOptions o;
  o.heads = 2;
  ag::Variable q(randn({1, 3, 4}, 1)), ctx(randn({1, 5, 6}, 2)), w(randn({8, 6}, 3));
  expect_error([&] { ag::mha_cross_ctx(q, ctx, ag::Variable(randn({8, 5}, 4)), {}, {}, {}, Tensor(), o); },
               {"mha_cross_ctx", "kv_weight must be (2 * D, C)", "[8, 5]"});
  expect_error([&] { ag::mha_cross_ctx(q, ag::Variable(randn({2, 5, 6}, 2)), w, {}, {}, {}, Tensor(), o); },
               {"mha_cross_ctx", "batch"});
  expect_error([&] { ag::mha_cross_ctx(q, ctx, w, ag::Variable(randn({4}, 5)), {}, {}, Tensor(), o); },
               {"mha_cross_ctx", "kv_bias"});
  expect_error([&] { ag::mha_cross_ctx(q, ctx, w, {}, ag::Variable(randn({2}, 6)), {}, Tensor(), o); },
               {"mha_cross_ctx", "both"});
  expect_error([&] { ag::mha_cross_ctx(q, ctx, w, {}, {}, {}, Tensor::ones({1, 4}), o); },
               {"mha_cross_ctx", "key_mask", "[1, 5]"});
  ag::MhaOptions causal = o;
  causal.causal = true;
  expect_error([&] { ag::mha_cross_ctx(q, ctx, w, {}, {}, {}, Tensor(), causal); }, {"mha_cross_ctx", "causal"});
  const ag::Variable q32(randn({1, 3, 4}, 1, DType::f32));
  expect_error([&] { ag::mha_cross_ctx(q32, ctx, w, {}, {}, {}, Tensor(), o); }, {"mha_cross_ctx", "dtypes differ"});
  // A head too long for the fused per-head loops (Tq * Tk > 64 * 64) is refused, and not chosen.
  EXPECT_FALSE(ag::mha_cross_ctx_chosen(80, 80, 1024, 2, 2));
  const ag::Variable q80(randn({1, 80, 4}, 1)), ctx80(randn({1, 80, 6}, 2));
  expect_error([&] { ag::mha_cross_ctx(q80, ctx80, w, {}, {}, {}, Tensor(), o); }, {"mha_cross_ctx", "not served"});
}
