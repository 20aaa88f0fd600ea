// test_text_encoder.cpp — the retrieval encoders: TextEncoder, MotionEncoder (models/text) and the GRU Evaluator
// (models/eval): output shapes, key-padding-mask invariance, float64 finite-difference checks of every parameter
// (and the motion input) on tiny configs, bad-input errors, and a tiny contrastive overfit (4 caption/motion pairs
// reach top-1 retrieval) for both pairs.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "autograd/no_grad.h"
#include "autograd/ops_elementwise.h"
#include "autograd/ops_join.h"
#include "autograd/ops_reduce.h"
#include "models/eval/evaluator.h"
#include "models/text/motion_encoder.h"
#include "models/text/text_encoder.h"
#include "models/text/text_motion_model.h"
#include "nn/loss_contrastive.h"
#include "nn/optim_adamw.h"
#include "tensor/ops.h"
#include "tensor/rng.h"
#include "test_tensor_util.h"

using namespace t2m;
using t2m::testing::randn;
using t2m::testing::expect_error;

namespace {

Tensor ids_of(const std::vector<int64_t>& v, int64_t B, int64_t L) { return Tensor::from_vector(v, {B, L}); }

Tensor mask_of(const std::vector<int64_t>& lengths, int64_t L, DType dt = DType::f32) {
  std::vector<double> m;
  for (int64_t n : lengths)
    for (int64_t t = 0; t < L; ++t) m.push_back(t < n ? 1.0 : 0.0);
  return Tensor::from_vector(m, {(int64_t)lengths.size(), L}).to(dt);
}

void randomise(nn::Module& m, uint64_t seed) {  // random values for every parameter (norm gains included)
  m.to(DType::f64);
  for (auto& p : m.parameters()) p.data().copy_(t2m::mul(randn(p.shape(), seed++), 0.4));
}

// Central differences of L = sum(f() * W) against backward() for every element of every Variable in wrt.
void fd_check(const std::function<ag::Variable()>& f, const std::vector<ag::Variable>& wrt, double tol = 1e-5) {
  for (const auto& v : wrt) v.clear_grad();
  ag::Variable y = f();
  const Tensor w = randn(y.shape(), 4321);
  y.backward(w);
  auto loss = [&] { return t2m::sum(t2m::mul(f().data(), w)).item(); };
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
      ASSERT_NEAR(g.data<double>()[j], num, tol * (1 + std::abs(num))) << "tensor " << i << " element " << j;
    }
  }
}

text::TextEncoderConfig tiny_text(int64_t vocab = 9) {
  text::TextEncoderConfig c;
  c.vocab = vocab, c.dim = 4, c.layers = 1, c.heads = 2, c.mlp_ratio = 2, c.max_len = 5, c.embed_dim = 3;
  return c;
}
text::MotionEncoderConfig tiny_motion(int64_t F = 3) {
  text::MotionEncoderConfig c;
  c.feature_dim = F, c.patch = 2, c.dim = 4, c.layers = 1, c.heads = 2, c.mlp_ratio = 2, c.max_patches = 4;
  c.embed_dim = 3;
  return c;
}
eval::EvaluatorConfig tiny_eval(int64_t vocab = 9, int64_t F = 3) {
  eval::EvaluatorConfig c;
  c.vocab = vocab, c.word_dim = 3, c.text_hidden = 3, c.max_len = 5, c.feature_dim = F, c.patch = 2;
  c.motion_hidden = 3, c.max_frames = 8, c.embed_dim = 3;
  return c;
}

}  // namespace

TEST(TextEncoder, ShapesAndParameterNames) {
  Generator g(1);
  text::TextEncoderConfig c;
  c.vocab = 20, c.max_len = 12;
  text::TextEncoder enc(c, g);
  const auto f = enc.forward(ids_of(std::vector<int64_t>(3 * 7, 5), 3, 7), mask_of({7, 4, 2}, 7));
  EXPECT_EQ(f.tokens.shape(), (Shape{3, 7, 256}));
  EXPECT_EQ(f.pooled.shape(), (Shape{3, 256}));
  const auto np = enc.named_parameters();
  EXPECT_EQ(np.front().first, "pos_emb");  // own parameters first, then the children in registration order
  EXPECT_EQ(np[1].first, "tok_emb.weight");
  EXPECT_EQ(np.back().first, "proj.bias");
}

TEST(TextEncoder, PaddingDoesNotChangeRealTokens) {
  Generator g(2);
  text::TextEncoder enc(tiny_text(), g);
  randomise(enc, 10);
  // Row 0: 3 real tokens; padded with ids 0 and length 4 vs. other ids and length 5.
  const auto a = enc.forward(ids_of({2, 5, 3, 0}, 1, 4), mask_of({3}, 4, DType::f64));
  const auto b = enc.forward(ids_of({2, 5, 3, 7, 8}, 1, 5), mask_of({3}, 5, DType::f64));
  EXPECT_LT(max_abs_diff(a.pooled.data(), b.pooled.data()), 1e-12);
  EXPECT_LT(max_abs_diff(a.tokens.data().slice(1, 0, 3), b.tokens.data().slice(1, 0, 3)), 1e-12);
  // A real token changes the output.
  const auto c2 = enc.forward(ids_of({2, 5, 4, 0}, 1, 4), mask_of({3}, 4, DType::f64));
  EXPECT_GT(max_abs_diff(a.pooled.data(), c2.pooled.data()), 1e-6);
}

TEST(TextEncoder, GradcheckFloat64AllParameters) {
  Generator g(3);
  text::TextEncoder enc(tiny_text(), g);
  randomise(enc, 20);
  const Tensor ids = ids_of({2, 4, 6, 3, 0, 2, 8, 3, 0, 0}, 2, 5), m = mask_of({4, 3}, 5, DType::f64);
  fd_check(
      [&] {
        const auto f = enc.forward(ids, m);
        // pooled plus the real tokens (padded rows are unspecified): (B, E) + sum over real tokens
        return ag::concat({f.pooled, ag::sum(f.tokens * ag::Variable(m.unsqueeze(2)), {1})}, 1);
      },
      enc.parameters());
}

TEST(TextEncoder, BadInput) {
  Generator g(4);
  text::TextEncoder enc(tiny_text(), g);
  expect_error([&] { enc.forward(ids_of(std::vector<int64_t>(6, 1), 1, 6), mask_of({6}, 6)); },
               {"TextEncoder", "max_len"});
  expect_error([&] { enc.forward(Tensor::zeros({1, 3}), mask_of({3}, 3)); }, {"TextEncoder", "int64"});
  expect_error([&] { enc.forward(ids_of({1, 2, 3}, 1, 3), mask_of({3}, 4)); }, {"TextEncoder", "mask"});
  expect_error([&] { enc.forward(ids_of({1, 2, 3}, 1, 3), mask_of({0}, 3)); }, {"no real entry"});
  expect_error([&] { enc.forward(ids_of({1, 9, 3}, 1, 3), mask_of({3}, 3)); }, {"9"});  // id >= vocab
  auto bad = tiny_text();
  bad.heads = 3;
  expect_error([&] { text::TextEncoder e(bad, g); }, {"TextEncoder", "divisible"});
  expect_error([&] { text::TextEncoderConfig::from_json({{"vocab", 3}}); }, {"TextEncoder", "dim"});
}

TEST(MotionEncoder, ShapesPaddingInvarianceAndErrors) {
  Generator g(5);
  text::MotionEncoder enc(tiny_motion(), g);
  randomise(enc, 30);
  EXPECT_EQ(enc.forward(ag::Variable(randn({2, 7, 3}, 1)), mask_of({7, 3}, 7, DType::f64)).shape(), (Shape{2, 3}));
  // 5 real frames: garbage in the padding and a longer padding change nothing.
  const Tensor x = randn({1, 8, 3}, 2);
  Tensor x2 = randn({1, 8, 3}, 3);
  x2.slice(1, 0, 5).copy_(x.slice(1, 0, 5));
  const auto a = enc.forward(ag::Variable(x.slice(1, 0, 5).contiguous()), mask_of({5}, 5, DType::f64));
  const auto b = enc.forward(ag::Variable(x2), mask_of({5}, 8, DType::f64));
  EXPECT_LT(max_abs_diff(a.data(), b.data()), 1e-12);
  const auto c = enc.forward(ag::Variable(x2), mask_of({6}, 8, DType::f64));
  EXPECT_GT(max_abs_diff(a.data(), c.data()), 1e-6);
  expect_error(
      [&] {
        enc.forward(ag::Variable(randn({1, 9, 3}, 4)), mask_of({9}, 9));
      },
      {"MotionEncoder", "max_patches"});
  expect_error(
      [&] {
        enc.forward(ag::Variable(randn({1, 4, 2}, 4)), mask_of({4}, 4));
      },
      {"MotionEncoder", "(B, T, 3)"});
  expect_error([&] { enc.forward(ag::Variable(randn({1, 4, 3}, 4)), mask_of({4}, 5)); }, {"MotionEncoder", "mask"});
  expect_error([&] { enc.forward(ag::Variable(randn({1, 4, 3}, 4)), mask_of({0}, 4)); }, {"no real entry"});
}

TEST(MotionEncoder, GradcheckFloat64ParametersAndInput) {
  Generator g(6);
  text::MotionEncoder enc(tiny_motion(), g);
  randomise(enc, 40);
  ag::Variable x(randn({2, 5, 3}, 7), true);
  const Tensor m = mask_of({5, 3}, 5, DType::f64);
  auto wrt = enc.parameters();
  wrt.push_back(x);
  fd_check([&] { return enc.forward(x, m); }, wrt);
}

TEST(Evaluator, ShapesPaddingInvarianceAndErrors) {
  Generator g(7);
  eval::Evaluator ev(tiny_eval(), g);
  randomise(ev, 50);
  EXPECT_EQ(ev.embed_text(ids_of({2, 3, 4, 2, 3, 0}, 2, 3), mask_of({3, 2}, 3, DType::f64)).shape(), (Shape{2, 3}));
  const auto t1 = ev.embed_text(ids_of({2, 3, 4, 0}, 1, 4), mask_of({3}, 4, DType::f64));
  const auto t2 = ev.embed_text(ids_of({2, 3, 4, 7, 1}, 1, 5), mask_of({3}, 5, DType::f64));
  EXPECT_LT(max_abs_diff(t1.data(), t2.data()), 1e-12);
  const Tensor x = randn({1, 8, 3}, 8);
  Tensor x2 = randn({1, 8, 3}, 9);
  x2.slice(1, 0, 4).copy_(x.slice(1, 0, 4));
  const auto m1 = ev.embed_motion(ag::Variable(x.slice(1, 0, 4).contiguous()), mask_of({4}, 4, DType::f64));
  const auto m2 = ev.embed_motion(ag::Variable(x2), mask_of({4}, 8, DType::f64));
  EXPECT_LT(max_abs_diff(m1.data(), m2.data()), 1e-12);
  expect_error(
      [&] {
        ev.embed_motion(ag::Variable(randn({1, 9, 3}, 4)), mask_of({9}, 9));
      },
      {"Evaluator", "max_frames"});
  expect_error([&] { ev.embed_text(ids_of({1, 2, 3, 4, 5, 6}, 1, 6), mask_of({6}, 6)); }, {"Evaluator", "max_len"});
  expect_error([&] { ev.embed_text(ids_of({1, 2}, 1, 2), mask_of({0}, 2)); }, {"Evaluator", "no real entry"});
  expect_error([&] { eval::EvaluatorConfig::from_json({{"vocab", 3}}); }, {"Evaluator", "word_dim"});
}

TEST(Evaluator, GradcheckFloat64AllParameters) {
  Generator g(8);
  eval::Evaluator ev(tiny_eval(6), g);
  randomise(ev, 60);
  const Tensor ids = ids_of({2, 4, 5, 3, 2, 3, 0, 0}, 2, 4), tm = mask_of({4, 2}, 4, DType::f64);
  ag::Variable x(randn({2, 5, 3}, 9), true);
  const Tensor mm = mask_of({5, 2}, 5, DType::f64);
  auto wrt = ev.parameters();
  wrt.push_back(x);
  fd_check([&] { return ag::concat({ev.embed_text(ids, tm), ev.embed_motion(x, mm)}, 1); }, wrt);
}

namespace {

// Trains a pair on 4 fixed (caption ids, motion) pairs with InfoNCE; returns how many texts retrieve their motion
// at top-1 among the 4 (cosine similarity).
int overfit_top1(text::RetrievalModel& m, int steps) {
  const Tensor ids = ids_of({2, 4, 5, 3, 0, 2, 6, 3, 0, 0, 2, 7, 8, 5, 3, 2, 4, 8, 3, 0}, 4, 5);
  const Tensor tm = mask_of({4, 3, 5, 4}, 5);
  const Tensor x = randn({4, 6, 3}, 77, DType::f32);
  const Tensor xm = mask_of({6, 6, 4, 5}, 6);
  auto params = m.named_parameters();
  ag::Variable alpha = ag::Variable::parameter(Tensor::full({1}, nn::kInitLogitScale), "logit_scale");
  params.emplace_back("logit_scale", alpha);
  nn::AdamWOptions o;
  o.lr = 1e-2, o.weight_decay = 0;
  nn::AdamW opt(params, o);
  m.train();
  for (int s = 0; s < steps; ++s) {
    opt.zero_grad();
    auto l = nn::info_nce(m.embed_motion(ag::Variable(x), xm), m.embed_text(ids, tm), alpha);
    l.loss.backward();
    opt.step();
  }
  ag::NoGradGuard ng;
  const Tensor t = nn::l2_normalize(m.embed_text(ids, tm)).data(),
               mo = nn::l2_normalize(m.embed_motion(ag::Variable(x), xm)).data();
  const Tensor sim = t2m::matmul(t, mo.transpose(0, 1));  // (4 texts, 4 motions)
  int hits = 0;
  for (int64_t i = 0; i < 4; ++i) {
    bool best = true;
    for (int64_t j = 0; j < 4; ++j)
      if (j != i && sim.at({i, j}) >= sim.at({i, i})) best = false;
    hits += best;
  }
  return hits;
}

}  // namespace

TEST(RetrievalOverfit, TextMotionModelReachesTop1) {
  Generator g(9);
  text::TextMotionConfig c{tiny_text(), tiny_motion()};
  c.text.dim = 8, c.motion.dim = 8, c.text.embed_dim = c.motion.embed_dim = 8;
  text::TextMotionModel m(c, g);
  EXPECT_EQ(overfit_top1(m, 150), 4);
}

TEST(RetrievalOverfit, EvaluatorReachesTop1) {
  Generator g(10);
  auto c = tiny_eval();
  c.word_dim = c.text_hidden = c.motion_hidden = c.embed_dim = 8;
  eval::Evaluator m(c, g);
  EXPECT_EQ(overfit_top1(m, 150), 4);
}
