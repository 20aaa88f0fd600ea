// test_text2bfm_flow_sampler.cpp — the Euler sampler of Text2BFM Eq 16 and classifier-free guidance
// (models/text2bfm/flow_sampler.h): toy analytic fields with known endpoints, guidance at w = 1 equals the
// conditional field, guided sampling equals the same guidance computed by hand with separate passes, seeds,
// bad input.
#include <gtest/gtest.h>

#include <cmath>

#include "autograd/no_grad.h"
#include "models/text2bfm/flow_sampler.h"
#include "tensor/ops.h"
#include "tensor/rng.h"
#include "test_tensor_util.h"

using namespace t2m;
using namespace t2m::text2bfm;
using t2m::testing::expect_error;

namespace {

double max_diff(const Tensor& a, const Tensor& b) { return amax(abs(sub(a.to(DType::f64), b.to(DType::f64)))).item(); }

FlowGeneratorConfig tiny() {
  FlowGeneratorConfig c;
  c.latent = 3, c.width = 8, c.depth = 1, c.heads = 2, c.ctx_dim = 6, c.mlp_ratio = 2, c.freq_dim = 8;
  c.adapter = TextAdapterConfig{.tok_dim = 5, .width = 4, .depth = 1, .heads = 2, .ctx_dim = 6, .max_len = 6};
  return c;
}

}  // namespace

// The rectified-flow field towards a fixed point a, v(m, r) = (a - m) / (1 - r), is exactly integrated by Euler:
// m_{k+1} - a = (m_k - a)(1 - h / (1 - r_k)) and the last step (r = 1 - h) lands on a.
TEST(FlowSampler, EulerRecoversTheEndpointOfTheStraightPath) {
  Generator g(1);
  const Tensor m0 = rand_normal({3, 4, 2}, g, 0.0, 1.0, DType::f64);
  const Tensor a = rand_normal({3, 4, 2}, g, 0.0, 1.0, DType::f64);
  int calls = 0;
  auto v = [&](const Tensor& m, const Tensor& r) {
    EXPECT_EQ(r.shape(), (Shape{3}));
    EXPECT_DOUBLE_EQ(r.at({1}), calls / 16.0);
    ++calls;
    return div(sub(a, m), add(mul(r, -1.0), 1.0).view({3, 1, 1}));
  };
  const Tensor m1 = euler_integrate(v, m0, 16);
  EXPECT_EQ(calls, 16);
  EXPECT_LT(max_diff(m1, a), 1e-12);
  EXPECT_GT(max_diff(m0, a), 0.5);
}

// A linear field v = lambda m: Euler gives m0 (1 + lambda h)^N exactly, and approaches m0 e^lambda as N grows.
TEST(FlowSampler, EulerOnALinearFieldMatchesTheDiscreteAndContinuousSolutions) {
  const Tensor m0 = Tensor::from_vector(std::vector<double>{1.0, -2.0, 0.5}, {3, 1});
  const double lambda = -1.3;
  auto v = [&](const Tensor& m, const Tensor&) { return mul(m, lambda); };
  for (int64_t n : {1, 4, 16}) {
    const Tensor m1 = euler_integrate(v, m0, n);
    EXPECT_LT(max_diff(m1, mul(m0, std::pow(1.0 + lambda / n, (double)n))), 1e-12) << n;
  }
  const double err16 = max_diff(euler_integrate(v, m0, 16), mul(m0, std::exp(lambda)));
  const double err256 = max_diff(euler_integrate(v, m0, 256), mul(m0, std::exp(lambda)));
  EXPECT_LT(err256, err16 / 10);  // first order: 16x the steps, ~16x smaller error
  EXPECT_LT(err256, 2e-3);
}

TEST(FlowSampler, GuidanceOneIsTheConditionalField) {
  Generator g(2);
  const Tensor vc = rand_normal({2, 3}, g), vu = rand_normal({2, 3}, g);
  EXPECT_EQ(max_diff(guided_velocity(vc, vu, 1.0), vc), 0.0);
  EXPECT_EQ(max_diff(guided_velocity(vc, vu, 0.0), vu), 0.0);
  EXPECT_LT(max_diff(guided_velocity(vc, vu, 1.5), add(vu, mul(sub(vc, vu), 1.5))), 1e-7);

  // with the generator: sampling at w = 1 is Euler on the conditional field alone
  Generator wg(3);
  FlowGenerator gen(tiny(), wg);
  const Tensor tok = rand_normal({2, 4, 5}, g);
  Tensor mask = Tensor::ones({2, 4});
  mask.set({0, 3}, 0.0);
  Generator r1(9), r2(9);
  const Tensor s = sample_programs(gen, tok, mask, 5, r1, {.steps = 4, .guidance = 1.0});
  const Tensor m0 = rand_normal({2, 5, 3}, r2);
  ag::NoGradGuard ng;
  const FlowContext cond = gen.encode_text(ag::Variable(tok), mask);
  const Tensor ref = euler_integrate(
      [&](const Tensor& m, const Tensor& r) { return gen.velocity(ag::Variable(m), r, cond).data(); }, m0, 4);
  EXPECT_LT(max_diff(s, ref), 1e-6);
}

TEST(FlowSampler, GuidedSamplingEqualsSeparateConditionalAndNullPasses) {
  Generator wg(4);
  FlowGenerator gen(tiny(), wg);
  Generator g(5);
  const Tensor tok = rand_normal({3, 4, 5}, g);
  Tensor mask = Tensor::ones({3, 4});
  mask.set({1, 2}, 0.0), mask.set({1, 3}, 0.0);
  const double w = 1.5;
  Generator r1(11), r2(11);
  const Tensor s = sample_programs(gen, tok, mask, 6, r1, {.steps = 16, .guidance = w});
  EXPECT_EQ(s.shape(), (Shape{3, 6, 3}));
  const Tensor m0 = rand_normal({3, 6, 3}, r2);
  ag::NoGradGuard ng;
  const FlowContext cond = gen.encode_text(ag::Variable(tok), mask), null = gen.null_context(3);
  const Tensor ref = euler_integrate(
      [&](const Tensor& m, const Tensor& r) {
        return guided_velocity(gen.velocity(ag::Variable(m), r, cond).data(),
                               gen.velocity(ag::Variable(m), r, null).data(), w);
      },
      m0, 16);
  EXPECT_LT(max_diff(s, ref), 1e-5);
  // guidance matters, and the seed fixes the sample
  Generator r3(11), r4(12);
  EXPECT_GT(max_diff(s, sample_programs(gen, tok, mask, 6, r3, {.steps = 16, .guidance = 1.0})), 1e-4);
  Generator r5(11);
  EXPECT_EQ(max_diff(s, sample_programs(gen, tok, mask, 6, r5, {.steps = 16, .guidance = w})), 0.0);
  EXPECT_GT(max_diff(s, sample_programs(gen, tok, mask, 6, r4, {.steps = 16, .guidance = w})), 1e-3);
}

TEST(FlowSampler, BadInputThrows) {
  auto v = [](const Tensor& m, const Tensor&) { return m; };
  const Tensor m0 = Tensor::zeros({2, 3});
  expect_error([&] { euler_integrate(v, m0, 0); }, {"flow_sampler", "steps"});
  expect_error([&] { euler_integrate([](const Tensor&, const Tensor&) { return Tensor::zeros({2}); }, m0, 2); },
               {"velocity field", "[2, 3]", "[2]"});
  expect_error([&] { guided_velocity(m0, Tensor::zeros({3, 2}), 1.5); }, {"equal shapes"});
  Generator wg(6), r(1);
  FlowGenerator gen(tiny(), wg);
  expect_error([&] { sample_programs(gen, Tensor::zeros({1, 2, 5}), Tensor(), 0, r); }, {"Tm"});
  expect_error([&] { sample_programs(gen, Tensor::zeros({1, 2, 4}), Tensor(), 3, r); }, {"tokens", "[1, 2, 4]"});
  expect_error([&] { sample_programs(gen, Tensor::zeros({1, 2, 5}), Tensor(), 3, r, {.steps = 16, .guidance = NAN}); },
               {"guidance"});
}
