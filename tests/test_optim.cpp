// test_optim.cpp — AdamW/SGD against naive scalar references, decoupled decay, schedules, clipping, NaN naming,
// EMA math, state save/load and the error paths.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <numbers>

#include "nn/ema.h"
#include "nn/grad_utils.h"
#include "nn/lr_schedule.h"
#include "nn/optim_adamw.h"
#include "nn/optim_sgd.h"
#include "tensor/parallel.h"
#include "tensor/rng.h"

using namespace t2m;
using nn::NamedParams;

namespace {

template <typename F>
void expect_error(F f, std::initializer_list<const char*> needles) {
  try {
    f();
    FAIL() << "expected t2m::Error";
  } catch (const Error& e) {
    std::string m = e.what();
    for (const char* n : needles) EXPECT_NE(m.find(n), std::string::npos) << "message: " << m << " lacks: " << n;
  }
}

NamedParams make_params(const std::vector<Shape>& shapes, DType dt, uint64_t seed) {
  Generator g(seed);
  NamedParams ps;
  for (size_t i = 0; i < shapes.size(); ++i)
  {
    std::string name = std::to_string(i);
    name.insert(0, 1, 'p');
    ps.emplace_back(name, ag::Variable::parameter(rand_normal(shapes[i], g, 0, 1, dt)));
  }
  return ps;
}

void set_grads(NamedParams& ps, Generator& g) {
  for (auto& [n, v] : ps) v.grad() = rand_normal(v.shape(), g, 0, 1, v.dtype());
}

// Textbook AdamW on doubles (Loshchilov & Hutter, Algorithm 2), one parameter.
struct RefAdamW {
  std::vector<double> p, m, v;
  void step(const std::vector<double>& g, double lr, double b1, double b2, double eps, double wd, int t) {
    for (size_t i = 0; i < p.size(); ++i) {
      p[i] -= lr * wd * p[i];
      m[i] = b1 * m[i] + (1 - b1) * g[i];
      v[i] = b2 * v[i] + (1 - b2) * g[i] * g[i];
      const double mh = m[i] / (1 - std::pow(b1, t)), vh = v[i] / (1 - std::pow(b2, t));
      p[i] -= lr * mh / (std::sqrt(vh) + eps);
    }
  }
};

void adamw_vs_reference(DType dt, double tol) {
  NamedParams ps = make_params({{3, 5}, {7}, {33}, {4, 25}, {1}}, dt, 1);
  nn::AdamWOptions o;
  o.lr = 0.01; o.beta1 = 0.8; o.beta2 = 0.95; o.eps = 1e-6; o.weight_decay = 0.3; o.no_decay = nn::no_decay_1d;
  nn::AdamW opt(ps, o);
  std::vector<RefAdamW> ref(ps.size());
  for (size_t i = 0; i < ps.size(); ++i) {
    ref[i].p = ps[i].second.data().to(DType::f64).to_vector<double>();
    ref[i].m.assign(ref[i].p.size(), 0.0);
    ref[i].v.assign(ref[i].p.size(), 0.0);
  }
  Generator g(7);
  for (int t = 1; t <= 8; ++t) {
    set_grads(ps, g);
    const double lr = 0.01 * t / 8.0;  // lr changes between steps, as under a schedule
    opt.set_lr(lr);
    opt.step();
    ASSERT_EQ(opt.step_count(), t);
    for (size_t i = 0; i < ps.size(); ++i) {
      const double wd = ps[i].second.dim() <= 1 ? 0.0 : 0.3;
      ref[i].step(ps[i].second.grad().to(DType::f64).to_vector<double>(), lr, 0.8, 0.95, 1e-6, wd, t);
      const auto p = ps[i].second.data().to(DType::f64).to_vector<double>();
      const auto m = opt.state("exp_avg", i).to(DType::f64).to_vector<double>();
      const auto v = opt.state("exp_avg_sq", i).to(DType::f64).to_vector<double>();
      for (size_t k = 0; k < p.size(); ++k) {
        ASSERT_NEAR(p[k], ref[i].p[k], tol * (1 + std::fabs(ref[i].p[k]))) << "step " << t << " param " << i << " el " << k;
        ASSERT_NEAR(m[k], ref[i].m[k], tol * (1 + std::fabs(ref[i].m[k])));
        ASSERT_NEAR(v[k], ref[i].v[k], tol * (1 + std::fabs(ref[i].v[k])));
      }
    }
  }
}

}  // namespace

TEST(AdamW, Float64MatchesNaiveScalarReferenceStepByStep) { adamw_vs_reference(DType::f64, 1e-13); }

TEST(AdamW, Float32FusedMultiTensorMatchesDoubleReference) { adamw_vs_reference(DType::f32, 2e-5); }

TEST(AdamW, WeightDecayIsDecoupledFromTheMoments) {
  for (DType dt : {DType::f32, DType::f64}) {
    NamedParams ps = make_params({{4, 3}, {3}}, dt, 3);
    const auto w0 = ps[0].second.data().to(DType::f64).to_vector<double>();
    const auto b0 = ps[1].second.data().to(DType::f64).to_vector<double>();
    nn::AdamWOptions o;
    o.lr = 0.1; o.weight_decay = 0.5; o.no_decay = nn::no_decay_1d;
    nn::AdamW opt(ps, o);
    EXPECT_TRUE(opt.decays(0));
    EXPECT_FALSE(opt.decays(1));
    // Zero gradient: the Adam part is exactly 0, so the weight only shrinks by (1 - lr wd) and the bias is unchanged.
    for (auto& [n, v] : ps) v.grad() = Tensor::zeros(v.shape(), dt);
    opt.step();
    const auto w1 = ps[0].second.data().to(DType::f64).to_vector<double>();
    const auto b1 = ps[1].second.data().to(DType::f64).to_vector<double>();
    for (size_t k = 0; k < w0.size(); ++k) EXPECT_NEAR(w1[k], w0[k] * (1 - 0.05), 1e-6 * std::fabs(w0[k]));
    for (size_t k = 0; k < b0.size(); ++k) EXPECT_EQ(b1[k], b0[k]);
    // The moments saw only the (zero) gradient, not wd * p as coupled L2 decay would put there.
    for (double m : opt.state("exp_avg", 0).to(DType::f64).to_vector<double>()) EXPECT_EQ(m, 0.0);
  }
}

TEST(AdamW, ParametersWithoutGradAreSkippedAndErrorsNameTheProblem) {
  NamedParams ps = make_params({{2, 2}, {3}}, DType::f32, 4);
  nn::AdamW opt(ps);
  const auto before = ps[1].second.data().to_vector<float>();
  ps[0].second.grad() = Tensor::ones({2, 2});
  opt.step();
  EXPECT_EQ(ps[1].second.data().to_vector<float>(), before);
  ps[1].second.grad() = Tensor::ones({4});
  expect_error([&] { opt.step(); }, {"AdamW", "p1", "[4]", "[3]"});
  expect_error([&] { nn::AdamW bad(NamedParams{ps[0], {"p0", ps[1].second}}); }, {"AdamW", "duplicate", "p0"});
  expect_error([&] { nn::AdamW bad(NamedParams{ps[0], {"again", ps[0].second}}); }, {"AdamW", "again", "same Variable"});
  nn::AdamWOptions o;
  o.beta2 = 1.0;
  expect_error([&] { nn::AdamW bad(ps, o); }, {"AdamW", "betas", "beta2=1"});
  expect_error([&] { opt.set_lr(-1); }, {"AdamW", "lr"});
  NamedParams ints{{"i", ag::Variable(Tensor::zeros({2}, DType::i64), false)}};
  expect_error([&] { nn::AdamW bad(ints); }, {"AdamW", "'i'", "i64"});
}

TEST(AdamW, StateRoundTripsThroughACheckpointAndChecksShapes) {
  NamedParams ps = make_params({{3, 4}, {4}}, DType::f32, 5);
  nn::AdamW opt(ps);
  Generator g(9);
  for (int i = 0; i < 3; ++i) { set_grads(ps, g); opt.step(); }
  nn::Checkpoint ck;
  opt.save_to(ck, "optim.");
  EXPECT_TRUE(ck.has("optim.exp_avg.p0"));
  EXPECT_TRUE(ck.has("optim.exp_avg_sq.p1"));
  NamedParams ps2 = make_params({{3, 4}, {4}}, DType::f32, 6);
  nn::AdamW opt2(ps2);
  opt2.load_from(ck, "optim.");
  EXPECT_EQ(opt2.step_count(), 3);
  for (size_t i = 0; i < 2; ++i)
    for (const char* s : {"exp_avg", "exp_avg_sq"})
      EXPECT_EQ(opt2.state(s, i).to_vector<float>(), opt.state(s, i).to_vector<float>());
  NamedParams ps3 = make_params({{3, 5}, {4}}, DType::f32, 6);
  nn::AdamW opt3(ps3);
  expect_error([&] { opt3.load_from(ck, "optim."); }, {"optim.exp_avg.p0", "[3, 4]", "[3, 5]"});
  EXPECT_EQ(opt3.step_count(), 0);  // a failed load changes nothing
  nn::SGD sgd(ps2, {});
  expect_error([&] { sgd.load_from(ck, "optim."); }, {"optim.momentum_buffer.p0"});
}

TEST(SGD, MomentumNesterovAndWeightDecayMatchNaiveReference) {
  struct Case { double mu, damp, wd; bool nest; };
  for (Case c : {Case{0, 0, 0, false}, Case{0.9, 0, 0, false}, Case{0.9, 0.1, 0.01, false}, Case{0.8, 0, 0.05, true}}) {
    NamedParams ps = make_params({{5}, {2, 3}}, DType::f64, 11);
    nn::SGDOptions o;
    o.lr = 0.05; o.momentum = c.mu; o.dampening = c.damp; o.weight_decay = c.wd; o.nesterov = c.nest;
    nn::SGD opt(ps, o);
    std::vector<std::vector<double>> p, b(2);
    for (auto& kv : ps) p.push_back(kv.second.data().to_vector<double>());
    Generator g(12);
    for (int t = 0; t < 4; ++t) {
      set_grads(ps, g);
      opt.step();
      for (size_t i = 0; i < 2; ++i) {
        auto gr = ps[i].second.grad().to_vector<double>();
        if (b[i].empty()) b[i].assign(gr.size(), 0.0);
        for (size_t k = 0; k < gr.size(); ++k) {
          double d = gr[k] + c.wd * p[i][k];
          if (c.mu != 0) {
            b[i][k] = t == 0 ? d : c.mu * b[i][k] + (1 - c.damp) * d;
            d = c.nest ? d + c.mu * b[i][k] : b[i][k];
          }
          p[i][k] -= 0.05 * d;
        }
        const auto got = ps[i].second.data().to_vector<double>();
        for (size_t k = 0; k < got.size(); ++k) ASSERT_NEAR(got[k], p[i][k], 1e-14) << "mu " << c.mu << " t " << t;
      }
    }
  }
  NamedParams ps = make_params({{2}}, DType::f32, 1);
  nn::SGDOptions bad;
  bad.nesterov = true;
  expect_error([&] { nn::SGD s(ps, bad); }, {"SGD", "nesterov", "momentum=0"});
}

TEST(SGD, MomentumStateRoundTripContinuesIdentically) {
  nn::SGDOptions o;
  o.lr = 0.1; o.momentum = 0.9; o.nesterov = true;
  NamedParams a = make_params({{3, 2}, {2}}, DType::f32, 21), b = make_params({{3, 2}, {2}}, DType::f32, 22);
  nn::SGD sa(a, o), sb(b, o);
  Generator g(23);
  for (int t = 0; t < 3; ++t) { set_grads(a, g); sa.step(); }
  nn::Checkpoint ck;
  for (auto& [n, v] : a) ck.put("model." + n, v.data());
  sa.save_to(ck, "sgd.");
  for (auto& [n, v] : b) v.data().copy_(ck.get("model." + n));
  sb.load_from(ck, "sgd.");
  EXPECT_EQ(sb.step_count(), 3);
  Generator g1(24), g2(24);
  set_grads(a, g1); sa.step();
  set_grads(b, g2); sb.step();
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].second.data().to_vector<float>(), b[i].second.data().to_vector<float>());
    EXPECT_EQ(sa.state("momentum_buffer", i).to_vector<float>(), sb.state("momentum_buffer", i).to_vector<float>());
  }
}

TEST(SGD, Float32MomentumFirstStepUsesTheGradient) {
  NamedParams ps{{"w", ag::Variable::parameter(Tensor::from_vector(std::vector<float>{1, 2}, {2}))}};
  nn::SGDOptions o;
  o.lr = 0.5; o.momentum = 0.9;
  nn::SGD opt(ps, o);
  ps[0].second.grad() = Tensor::from_vector(std::vector<float>{2, -4}, {2});
  opt.step();  // b = g; p = p - 0.5 g
  EXPECT_EQ(ps[0].second.data().to_vector<float>(), (std::vector<float>{0, 4}));
  opt.step();  // b = 0.9 g + g = 1.9 g
  EXPECT_NEAR(ps[0].second.data().to_vector<float>()[0], 0 - 0.5 * 1.9 * 2, 1e-6);
  EXPECT_NEAR(ps[0].second.data().to_vector<float>()[1], 4 + 0.5 * 1.9 * 4, 1e-6);
}

TEST(LrSchedule, WarmupCosineAndConstantAtKeySteps) {
  const auto s = nn::LrSchedule::warmup_cosine(1.0, 10, 110, 0.1);
  EXPECT_DOUBLE_EQ(s.at(0), 0.1);
  EXPECT_DOUBLE_EQ(s.at(4), 0.5);
  EXPECT_DOUBLE_EQ(s.at(9), 1.0);
  EXPECT_DOUBLE_EQ(s.at(10), 1.0);                       // cosine starts at base
  EXPECT_NEAR(s.at(60), 0.55, 1e-15);                     // halfway: floor + (base - floor) / 2
  EXPECT_NEAR(s.at(35), 0.1 + 0.9 * 0.5 * (1 + std::cos(std::numbers::pi / 4)), 1e-15);
  EXPECT_DOUBLE_EQ(s.at(110), 0.1);
  EXPECT_DOUBLE_EQ(s.at(100000), 0.1);
  for (int64_t t = 10; t < 110; ++t) EXPECT_LE(s.at(t + 1), s.at(t));  // monotone after the warm-up
  const auto c = nn::LrSchedule::constant_lr(0.3, 4);
  EXPECT_DOUBLE_EQ(c.at(0), 0.075);
  EXPECT_DOUBLE_EQ(c.at(3), 0.3);
  EXPECT_DOUBLE_EQ(c.at(1000), 0.3);
  EXPECT_DOUBLE_EQ(nn::LrSchedule::warmup_cosine(2.0, 0, 4).at(2), 1.0);
  expect_error([] { nn::LrSchedule::warmup_cosine(1.0, 10, 10); }, {"LrSchedule", "total (10)", "warmup (10)"});
  expect_error([] { nn::LrSchedule::warmup_cosine(1.0, 0, 10, 2.0); }, {"LrSchedule", "floor"});
  expect_error([&] { s.at(-1); }, {"LrSchedule", "step", "-1"});
}

TEST(GradUtils, ClipGradNormUsesTheGlobalNormInAFixedOrder) {
  NamedParams ps{{"a", ag::Variable::parameter(Tensor::zeros({2}))},
                 {"b", ag::Variable::parameter(Tensor::zeros({2, 1}, DType::f32))},
                 {"c", ag::Variable::parameter(Tensor::zeros({3}))}};  // c has no grad
  ps[0].second.grad() = Tensor::from_vector(std::vector<float>{3, 4}, {2});
  ps[1].second.grad() = Tensor::from_vector(std::vector<float>{12, 0}, {2, 1});
  EXPECT_DOUBLE_EQ(nn::grad_norm(ps), 13.0);
  EXPECT_DOUBLE_EQ(nn::clip_grad_norm(ps, 100.0), 13.0);  // below the limit: unchanged
  EXPECT_EQ(ps[0].second.grad().to_vector<float>(), (std::vector<float>{3, 4}));
  EXPECT_DOUBLE_EQ(nn::clip_grad_norm(ps, 6.5), 13.0);    // returns the norm before clipping
  EXPECT_NEAR(nn::grad_norm(ps), 6.5, 1e-5);
  EXPECT_NEAR(ps[0].second.grad().to_vector<float>()[1], 2.0, 1e-6);
  EXPECT_NEAR(ps[1].second.grad().to_vector<float>()[0], 6.0, 1e-6);
  // A larger random case against a naive double sum.
  NamedParams big = make_params({{1000}, {17, 13}}, DType::f32, 2);
  Generator g(3);
  set_grads(big, g);
  double ss = 0;
  for (auto& [n, v] : big)
    for (float x : v.grad().to_vector<float>()) ss += (double)x * x;
  EXPECT_NEAR(nn::grad_norm(big), std::sqrt(ss), 1e-12 * std::sqrt(ss));
  expect_error([&] { nn::clip_grad_norm(ps, 0.0); }, {"clip_grad_norm", "max_norm"});
  // Many blocks: the same bits for 1 and 2 threads, and close to the naive sum.
  NamedParams huge = make_params({{100000}, {3}, {70001}}, DType::f32, 4);
  set_grads(huge, g);
  double hs = 0;
  for (auto& [n, v] : huge)
    for (float x : v.grad().to_vector<float>()) hs += (double)x * x;
  const int saved = get_num_threads();
  set_num_threads(1);
  const double n1 = nn::grad_norm(huge);
  set_num_threads(2);
  const double n2 = nn::grad_norm(huge);
  set_num_threads(saved);
  EXPECT_EQ(n1, n2);
  EXPECT_NEAR(n1, std::sqrt(hs), 1e-12 * std::sqrt(hs));
}

TEST(GradUtils, CheckFiniteGradsNamesTheFirstBadParameterAndCounts) {
  NamedParams ps = make_params({{4}, {2, 3}, {5}}, DType::f32, 8);
  for (auto& [n, v] : ps) v.grad() = Tensor::ones(v.shape());
  EXPECT_NO_THROW(nn::check_finite_grads(ps));
  ps[1].second.grad().set({0, 2}, NAN);
  ps[1].second.grad().set({1, 1}, INFINITY);
  ps[2].second.grad().set({0}, -INFINITY);
  expect_error([&] { nn::check_finite_grads(ps); }, {"'p1'", "[2, 3]", "2 non-finite", "flat index 2", "nan", "2 parameter(s)"});
  EXPECT_FALSE(std::isfinite(nn::clip_grad_norm(ps, 1.0)));
  EXPECT_TRUE(std::isnan(ps[1].second.grad().to_vector<float>()[2]));
  EXPECT_EQ(ps[0].second.grad().to_vector<float>()[0], 1.0f);  // non-finite norm: grads left unchanged
}

TEST(Ema, MathApplyRestoreAndSaveLoad) {
  NamedParams ps{{"w", ag::Variable::parameter(Tensor::from_vector(std::vector<double>{1.0, -2.0}, {2}))}};
  nn::Ema ema(ps, 0.9);
  std::vector<double> s{1.0, -2.0};
  for (int t = 0; t < 3; ++t) {
    Tensor& p = ps[0].second.data();
    p.set({0}, p.at({0}) + 1.0);
    p.set({1}, p.at({1}) * 0.5);
    ema.update();
    s[0] = 0.9 * s[0] + 0.1 * p.at({0});
    s[1] = 0.9 * s[1] + 0.1 * p.at({1});
  }
  EXPECT_NEAR(ema.shadow(0).at({0}), s[0], 1e-15);
  EXPECT_NEAR(ema.shadow(0).at({1}), s[1], 1e-15);
  EXPECT_NEAR(s[0], 0.9 * 0.9 * 0.9 * 1 + 0.1 * (0.81 * 2 + 0.9 * 3 + 4), 1e-15);  // closed form
  const auto train = ps[0].second.data().to_vector<double>();
  {
    nn::EmaScope scope(ema);
    EXPECT_EQ(ps[0].second.data().to_vector<double>(), ema.shadow(0).to_vector<double>());
    expect_error([&] { ema.apply(); }, {"Ema", "apply() called twice"});
    expect_error([&] { ema.update(); }, {"Ema", "update() while"});
  }
  EXPECT_EQ(ps[0].second.data().to_vector<double>(), train);
  expect_error([&] { ema.restore(); }, {"Ema", "restore() without apply()"});
  nn::Ema warm(ps, 0.999, true);
  EXPECT_DOUBLE_EQ(warm.decay_at(0), 0.1);
  EXPECT_DOUBLE_EQ(warm.decay_at(10), 11.0 / 20.0);
  EXPECT_DOUBLE_EQ(warm.decay_at(100000), 0.999);
  nn::Checkpoint ck;
  ema.save_to(ck, "ema.");
  NamedParams ps2{{"w", ag::Variable::parameter(Tensor::zeros({2}, DType::f64))}};
  nn::Ema e2(ps2, 0.9);
  e2.load_from(ck, "ema.");
  EXPECT_EQ(e2.num_updates(), 3);
  EXPECT_EQ(e2.shadow(0).to_vector<double>(), ema.shadow(0).to_vector<double>());
  NamedParams ps3{{"w", ag::Variable::parameter(Tensor::zeros({3}, DType::f64))}};
  nn::Ema e3(ps3, 0.9);
  expect_error([&] { e3.load_from(ck, "ema."); }, {"ema.w", "[3]", "[2]"});
  expect_error([&] { nn::Ema bad(ps, 1.5); }, {"Ema", "decay", "[0, 1]"});
}
