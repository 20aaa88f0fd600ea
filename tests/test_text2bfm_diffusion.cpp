// test_text2bfm_diffusion.cpp — the generator's diffusion variant (Table 5): VP noise schedules
// (nn/diffusion_schedule.h), the v-prediction loss (nn/loss_diffusion.h: values, float64 gradchecks), DDIM on toy
// analytic fields (models/text2bfm/diffusion_sampler.h: a point mass is recovered exactly, Gaussian data follow
// the probability-flow map x -> s x), the guided sampler on a tiny generator, the "diffusion" objective of the
// training loop and its checkpoint tag.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <numbers>

#include "autograd/autograd.h"
#include "models/text2bfm/diffusion_sampler.h"
#include "models/text2bfm/gen_train.h"
#include "models/text2bfm/pipeline_checkpoints.h"
#include "nn/loss_diffusion.h"
#include "nn/train_log.h"
#include "tensor/ops.h"
#include "test_tensor_util.h"

using namespace t2m;
using ag::Variable;
using VV = std::vector<Variable>;
using t2m::testing::random_tensor;
namespace fs = std::filesystem;

namespace {

void expect_gradcheck(const ag::GradcheckFn& f, const std::vector<Tensor>& in) {
  ag::GradcheckResult r = ag::gradcheck(f, in);
  EXPECT_TRUE(r.ok) << r.message;
}

text2bfm::FlowGeneratorConfig tiny_gen() {
  text2bfm::FlowGeneratorConfig c;
  c.latent = 3, c.width = 16, c.depth = 1, c.heads = 2, c.ctx_dim = 8, c.freq_dim = 8;
  c.adapter = {.tok_dim = 5, .width = 8, .depth = 1, .heads = 2, .ctx_dim = 8, .max_len = 6};
  return c;
}

}  // namespace

TEST(DiffusionSchedule, CosineAndLinearClosedForms) {
  using nn::NoiseSchedule;
  const double h = std::numbers::pi / 2, s = 0.008;
  for (double t : {0.0, 0.1, 0.5, 0.9, 1.0}) {
    const double want = t == 1.0 ? 0.0 : std::cos(h * (t + s) / (1 + s)) / std::cos(h * s / (1 + s));
    EXPECT_NEAR(nn::schedule_alpha(NoiseSchedule::cosine, t), want, 1e-15) << t;
    EXPECT_NEAR(nn::schedule_alpha(NoiseSchedule::linear, t), std::exp(-0.5 * (0.1 * t + 9.95 * t * t)), 1e-15);
    for (auto k : {NoiseSchedule::cosine, NoiseSchedule::linear}) {  // variance preserving
      const double a = nn::schedule_alpha(k, t), sg = nn::schedule_sigma(k, t);
      EXPECT_NEAR(a * a + sg * sg, 1.0, 1e-12);
    }
  }
  EXPECT_EQ(nn::schedule_alpha(NoiseSchedule::cosine, 0.0), 1.0);
  EXPECT_EQ(nn::schedule_sigma(NoiseSchedule::cosine, 0.0), 0.0);
  EXPECT_EQ(nn::schedule_alpha(NoiseSchedule::cosine, 1.0), 0.0);
  EXPECT_NEAR(nn::schedule_alpha(NoiseSchedule::cosine, 0.5), 0.70274, 1e-5);
  for (int i = 1; i <= 100; ++i)  // alpha decreases in t
    EXPECT_LT(nn::schedule_alpha(NoiseSchedule::cosine, i / 100.0), nn::schedule_alpha(NoiseSchedule::cosine, (i - 1) / 100.0));
  const Tensor t = Tensor::from_vector(std::vector<float>{0.f, 0.25f, 0.75f}, {3});
  const Tensor a = nn::schedule_alphas(NoiseSchedule::cosine, t);
  EXPECT_EQ(a.dtype(), DType::f32);
  EXPECT_NEAR(a.at({1}), nn::schedule_alpha(NoiseSchedule::cosine, 0.25), 1e-7);
  EXPECT_THROW(nn::schedule_alpha(NoiseSchedule::cosine, 1.5), Error);
  EXPECT_THROW(nn::schedule_alpha(NoiseSchedule::linear, -0.1), Error);
  EXPECT_THROW(nn::noise_schedule_from_name("quadratic"), Error);
  EXPECT_EQ(nn::noise_schedule_from_name("linear"), NoiseSchedule::linear);
}

TEST(DiffusionLoss, ValuesAgainstNaiveLoops) {
  const Tensor x = random_tensor({2, 3, 2}, DType::f64, 1), eps = random_tensor({2, 3, 2}, DType::f64, 2);
  const Tensor v = random_tensor({2, 3, 2}, DType::f64, 3);
  const Tensor al = Tensor::from_vector(std::vector<double>{0.9, 0.3}, {2});
  const Tensor sg = Tensor::from_vector(std::vector<double>{std::sqrt(1 - 0.81), std::sqrt(1 - 0.09)}, {2});
  const nn::DiffusionPoint p = nn::diffusion_interpolate(Variable(x), Variable(eps), Variable(al), Variable(sg));
  Tensor w = Tensor::ones({2, 3, 1}, DType::f64);
  w.set({1, 2, 0}, 0.0);  // a padded frame
  nn::MseOptions mo;
  mo.weights = w;
  const double loss = nn::diffusion_v_loss(Variable(v), Variable(x), Variable(eps), Variable(al), Variable(sg), mo).item();
  double sum = 0, n = 0;
  for (int64_t b = 0; b < 2; ++b)
    for (int64_t i = 0; i < 3; ++i)
      for (int64_t d = 0; d < 2; ++d) {
        const double a = al.at({b}), s = sg.at({b}), xx = x.at({b, i, d}), e = eps.at({b, i, d});
        EXPECT_NEAR(p.x_t.data().at({b, i, d}), a * xx + s * e, 1e-15);
        EXPECT_NEAR(p.v.data().at({b, i, d}), a * e - s * xx, 1e-15);
        // x̂ = alpha x_t − sigma v recovers the data
        EXPECT_NEAR(a * p.x_t.data().at({b, i, d}) - s * p.v.data().at({b, i, d}), xx, 1e-14);
        if (b == 1 && i == 2) continue;
        const double r = v.at({b, i, d}) - (a * e - s * xx);
        sum += r * r, n += 1;
      }
  EXPECT_NEAR(loss, sum / n, 1e-14);
  EXPECT_THROW(nn::diffusion_v_loss(Variable(v), Variable(x), Variable(eps.narrow(1, 0, 2)), Variable(al), Variable(sg)),
               Error);
  EXPECT_THROW(nn::diffusion_interpolate(Variable(x), Variable(eps), Variable(Tensor::ones({3}, DType::f64)), Variable(sg)),
               Error);
  EXPECT_THROW(nn::diffusion_interpolate(Variable(x), Variable(eps), Variable(al.to(DType::f32)), Variable(sg)), Error);
}

TEST(DiffusionLoss, Gradcheck) {
  const Tensor x = random_tensor({2, 3, 2}, DType::f64, 4), eps = random_tensor({2, 3, 2}, DType::f64, 5);
  const Tensor v = random_tensor({2, 3, 2}, DType::f64, 6);
  const Tensor al = Tensor::from_vector(std::vector<double>{0.8, 0.4}, {2});
  const Tensor sg = Tensor::from_vector(std::vector<double>{0.6, 0.9165}, {2});
  expect_gradcheck([](const VV& a) { return nn::diffusion_interpolate(a[0], a[1], a[2], a[3]).x_t; }, {x, eps, al, sg});
  expect_gradcheck([](const VV& a) { return nn::diffusion_interpolate(a[0], a[1], a[2], a[3]).v; }, {x, eps, al, sg});
  expect_gradcheck([](const VV& a) { return nn::diffusion_v_loss(a[0], a[1], a[2], a[3], a[4]); },
                   {v, x, eps, al, sg});
  nn::MseOptions mo;
  Tensor w = Tensor::ones({2, 3, 1}, DType::f64);
  w.set({0, 1, 0}, 0.0);
  mo.weights = w;
  expect_gradcheck([mo](const VV& a) { return nn::diffusion_v_loss(a[0], a[1], a[2], a[3], a[4], mo); },
                   {v, x, eps, al, sg});
}

TEST(DiffusionLoss, TrainingDrawIsConsistentAndDeterministic) {
  const Tensor x = random_tensor({4, 2, 3}, DType::f32, 7);
  Generator g1(3), g2(3);
  const auto a = nn::sample_diffusion_pair(x, g1), b = nn::sample_diffusion_pair(x, g2);
  EXPECT_EQ(a.x_t.to_vector<float>(), b.x_t.to_vector<float>());
  for (int64_t i = 0; i < 4; ++i) {
    const double t = a.t.at({i});
    EXPECT_TRUE(t >= 0 && t < 1);
    EXPECT_NEAR(a.alpha.at({i}), nn::schedule_alpha(nn::NoiseSchedule::cosine, t), 1e-6);
    EXPECT_NEAR(a.x_t.at({i, 1, 2}), a.alpha.at({i}) * x.at({i, 1, 2}) + a.sigma.at({i}) * a.eps.at({i, 1, 2}), 1e-5);
    EXPECT_NEAR(a.v.at({i, 0, 1}), a.alpha.at({i}) * a.eps.at({i, 0, 1}) - a.sigma.at({i}) * x.at({i, 0, 1}), 1e-5);
  }
}

// The exact v-prediction of a point mass at x*: v(x, t) = alpha (x − alpha x*) / sigma − sigma x*.
TEST(Ddim, RecoversAPointMassExactly) {
  const Tensor target = random_tensor({2, 3, 2}, DType::f64, 8);
  const auto sched = nn::NoiseSchedule::cosine;
  auto field = [&](const Tensor& x, const Tensor& r) {
    const double t = 1.0 - r.at({0});
    const double a = nn::schedule_alpha(sched, t), s = nn::schedule_sigma(sched, t);
    return sub(mul(sub(x, mul(target, a)), a / s), mul(target, s));
  };
  for (int64_t steps : {1, 5, 50}) {
    const Tensor x1 = random_tensor({2, 3, 2}, DType::f64, 9);
    const Tensor out = text2bfm::ddim_integrate(field, x1, steps, sched);
    const auto o = out.to_vector<double>(), w = target.to_vector<double>();
    for (size_t i = 0; i < o.size(); ++i) EXPECT_NEAR(o[i], w[i], 1e-12) << steps;
  }
}

// Data N(0, s^2 I): E[x|x_t] = alpha s^2 x_t / (alpha^2 s^2 + sigma^2), E[eps|x_t] = sigma x_t / (same), so
// v = alpha sigma (1 − s^2) x_t / (alpha^2 s^2 + sigma^2); the probability-flow map from t = 1 to 0 is x -> s x.
TEST(Ddim, GaussianDataFollowTheProbabilityFlow) {
  const double sd = 0.5;
  for (auto sched : {nn::NoiseSchedule::cosine, nn::NoiseSchedule::linear}) {
    auto field = [&](const Tensor& x, const Tensor& r) {
      const double t = 1.0 - r.at({0});
      const double a = nn::schedule_alpha(sched, t), s = nn::schedule_sigma(sched, t);
      return mul(x, a * s * (1 - sd * sd) / (a * a * sd * sd + s * s));
    };
    const Tensor x1 = random_tensor({3, 4}, DType::f64, 10);
    const Tensor out = text2bfm::ddim_integrate(field, x1, 400, sched);
    const auto o = out.to_vector<double>(), in = x1.to_vector<double>();
    double err = 0;
    for (size_t i = 0; i < o.size(); ++i) err = std::max(err, std::fabs(o[i] - sd * in[i]));
    EXPECT_LT(err, 0.01) << nn::noise_schedule_name(sched);
    const Tensor coarse = text2bfm::ddim_integrate(field, x1, 10, sched);
    double err10 = 0;
    for (size_t i = 0; i < o.size(); ++i) err10 = std::max(err10, std::fabs(coarse.to_vector<double>()[i] - sd * in[i]));
    EXPECT_LT(err, err10);  // more steps, closer to the ODE
  }
  auto bad = [](const Tensor& x, const Tensor&) { return x.narrow(0, 0, 1); };
  EXPECT_THROW(text2bfm::ddim_integrate(bad, Tensor::zeros({2, 2}), 3, nn::NoiseSchedule::cosine), Error);
  EXPECT_THROW(text2bfm::ddim_integrate(bad, Tensor::zeros({2, 2}), 0, nn::NoiseSchedule::cosine), Error);
}

TEST(Ddim, GuidedSamplerOnATinyGenerator) {
  Generator g(2);
  text2bfm::FlowGenerator gen(tiny_gen(), g);
  gen.eval();
  const Tensor tok = random_tensor({2, 4, 5}, DType::f32, 11);
  const Tensor mask = Tensor::ones({2, 4});
  Generator r1(5), r2(5), r3(5);
  text2bfm::DiffusionSamplerOptions o;
  o.steps = 7;
  const Tensor a = text2bfm::sample_programs_diffusion(gen, tok, mask, 3, r1, o);
  const Tensor b = text2bfm::sample_programs_diffusion(gen, tok, mask, 3, r2, o);
  EXPECT_EQ(a.shape(), (Shape{2, 3, 3}));
  EXPECT_EQ(a.to_vector<float>(), b.to_vector<float>());
  // The same as DDIM on the guided field from the same noise.
  const Tensor x1 = rand_normal({2, 3, 3}, r3, 0.0, 1.0, DType::f32);
  const Tensor c = text2bfm::ddim_integrate(text2bfm::guided_field(gen, tok, mask, 1.5), x1, 7, o.schedule);
  const auto av = a.to_vector<float>(), cv = c.to_vector<float>();
  for (size_t i = 0; i < av.size(); ++i) EXPECT_NEAR(av[i], cv[i], 1e-6);
  EXPECT_THROW(text2bfm::sample_programs_diffusion(gen, tok, mask, 0, r1, o), Error);
}

TEST(GenTrainDiffusion, LossFallsAndCheckpointKeepsTheObjective) {
  Generator g(1);
  text2bfm::VbbConfig vc;
  vc.in_dim = 6, vc.width = 8, vc.latent = 3, vc.levels = 2, vc.depth = 1, vc.groups = 4;
  text2bfm::Vbb vbb(vc, g);
  vbb.eval();
  Generator g5(5);
  std::vector<Tensor> z = {rand_normal({9, 6}, g5), rand_normal({16, 6}, g5), rand_normal({4, 6}, g5)};
  Tensor tok = rand_normal({6, 6, 5}, g5), mask = Tensor::ones({6, 6});
  const auto d = text2bfm::make_program_dataset(text2bfm::encode_programs(vbb, z), {{0, 1}, {2, 3}, {4, 5}}, tok,
                                                mask, 3);
  text2bfm::GenTrainConfig cfg;
  cfg.steps = 200, cfg.batch = 16, cfg.lr = 1e-2, cfg.warmup = 5, cfg.save_every = 50;
  cfg.objective = "diffusion";
  const fs::path dir = fs::temp_directory_path() / ("t2m_diffusion_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const text2bfm::GenTrainPaths p{(dir / "s.ckpt").string(), (dir / "log.jsonl").string(), ""};
  Generator gi(7);
  auto model = std::make_shared<text2bfm::FlowGenerator>(tiny_gen(), gi);
  EXPECT_EQ(text2bfm::train_generator(*model, d, cfg, p, false).steps, 200);
  const auto log = nn::read_train_log(p.log);
  ASSERT_EQ(log.size(), 200u);
  double first = 0, last = 0;
  for (int i = 0; i < 20; ++i) first += log[i]["loss"].get<double>(), last += log[180 + i]["loss"].get<double>();
  EXPECT_LT(last, 0.8 * first);
  auto bad = cfg;
  bad.objective = "score";
  EXPECT_THROW(bad.validate(), Error);
  bad.objective = "diffusion", bad.schedule = "quadratic";
  EXPECT_THROW(bad.validate(), Error);

  text2bfm::GenBundle b;
  b.model = model;
  b.program_mean = d.mean, b.program_std = d.std, b.compression = 4, b.window = 3;
  b.objective = "diffusion", b.schedule = "linear";
  const std::string path = (dir / "gen.t2mckpt").string();
  text2bfm::save_gen_checkpoint(b, path);
  const auto l = text2bfm::load_gen_checkpoint(path);
  EXPECT_EQ(l.objective, "diffusion");
  EXPECT_EQ(l.schedule, "linear");
  b.objective = "flow";
  text2bfm::save_gen_checkpoint(b, path);
  EXPECT_EQ(text2bfm::load_gen_checkpoint(path).objective, "flow");
  b.objective = "score";
  EXPECT_THROW(text2bfm::save_gen_checkpoint(b, path), Error);
  fs::remove_all(dir);
}
