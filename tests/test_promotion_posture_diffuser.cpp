// test_promotion_posture_diffuser.cpp — the posture diffuser: its schedule (linear 0.00085..0.012), q(x_t | x_0),
// guided sampling (determinism, shapes, guidance), checkpoint round trip, resumable training, a tiny overfit that
// turns scripts into their poses, and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "autograd/no_grad.h"
#include "models/promotion/diffusion_schedule.h"
#include "models/promotion/posture_diffuser.h"
#include "models/promotion/posture_diffuser_sampler.h"
#include "models/promotion/posture_diffuser_train.h"
#include "tensor/ops.h"
#include "tensor/parallel.h"
#include "tensor/rng.h"

namespace {

using namespace t2m;
using namespace t2m::promotion;
namespace fs = std::filesystem;

PostureDiffuserConfig tiny_config(const text::Tokenizer& tok) {
  PostureDiffuserConfig c;
  c.width = 64;
  c.layers = 2;
  c.heads = 2;
  c.text_dim = 32;
  c.max_tokens = 24;
  c.vocab = tok.vocab_size();
  c.diffusion_steps = 50;
  c.beta_start = 0.00085 * 20;  // the same linear shape, fewer steps (tests only)
  c.beta_end = 0.012 * 20;
  return c;
}

// Four distinct normalised "poses" with four distinct scripts.
PostureTrainData tiny_data(const text::Tokenizer& tok, int64_t max_tokens) {
  const std::vector<std::string> scripts = {"both elbows are straight.", "the left elbow is completely bent.",
                                            "both feet are off the ground.", "the hands are wide apart."};
  std::vector<float> x((size_t)4 * kPoseDim);
  for (int i = 0; i < 4; ++i)
    for (int d = 0; d < kPoseDim; ++d) x[(size_t)i * kPoseDim + d] = (float)std::sin(0.37 * d * (i + 1) + i);
  PostureTrainData data;
  data.x0 = Tensor::from_vector(x, {4, kPoseDim});
  const text::EncodedBatch e = tok.encode_batch(scripts, max_tokens);
  data.ids = e.ids;
  data.mask = e.mask;
  return data;
}

fs::path temp_dir(const std::string& name) {
  fs::path p = fs::temp_directory_path() / ("t2m_test_posture_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

TEST(PostureDiffuser, ScheduleIsThePapersLinearBetas) {
  PostureDiffuserConfig c;  // defaults = the shipped model
  EXPECT_EQ(c.diffusion_steps, 1000);
  const DiffusionSchedule s = DiffusionSchedule::linear((int)c.diffusion_steps, c.beta_start, c.beta_end);
  EXPECT_DOUBLE_EQ(s.beta(0), 0.00085);
  EXPECT_NEAR(s.beta(999), 0.012, 1e-15);
  EXPECT_NEAR(s.beta(500), 0.00085 + (0.012 - 0.00085) * 500.0 / 999.0, 1e-15);
  double ab = 1.0;
  for (int t = 0; t < 1000; ++t) ab *= 1.0 - s.beta(t);
  EXPECT_NEAR(s.alpha_bar(999), ab, 1e-12);
  EXPECT_LT(s.alpha_bar(999), 0.01);  // x_T is (almost) pure noise
}

TEST(PostureDiffuser, ForwardProcessMatchesQ) {
  // q(x_t | x_0) = N(sqrt(abar) x_0, (1 - abar) I): empirical mean and variance over many draws.
  PostureDiffuserConfig c;
  const DiffusionSchedule s = DiffusionSchedule::linear(1000, c.beta_start, c.beta_end);
  const int64_t N = 20000;
  const int t = 300;
  Generator g(5);
  const Tensor x0 = Tensor::full({N, 1}, 1.5);
  const Tensor x_t = s.q_sample(x0, Tensor::full({N}, t, DType::i64), rand_normal({N, 1}, g));
  const auto v = x_t.to_vector<float>();
  double m = 0, q = 0;
  for (float f : v) m += f;
  m /= N;
  for (float f : v) q += (f - m) * (f - m);
  q /= N - 1;
  const double ab = s.alpha_bar(t);
  EXPECT_NEAR(m, std::sqrt(ab) * 1.5, 0.02);
  EXPECT_NEAR(q, 1 - ab, 0.02);
}

TEST(PostureDiffuser, SamplingIsSeededAndGuided) {
  const text::Tokenizer tok = script_tokenizer();
  Generator g(3);
  PostureModel m;
  m.net = std::make_shared<PostureDiffuser>(tiny_config(tok), g);
  m.net->eval();
  m.tokenizer = tok;
  m.stats.mean.assign(kPoseDim, 0.5f);
  m.stats.std.assign(kPoseDim, 2.0f);
  const std::vector<std::string> scripts = {"both knees are straight.", "the hands are close together."};
  const auto a = sample_postures(m, scripts, 3, 7);
  ASSERT_EQ(a.size(), 2u * 3 * kPoseDim);
  for (float f : a) ASSERT_TRUE(std::isfinite(f));
  EXPECT_EQ(a, sample_postures(m, scripts, 3, 7));
  EXPECT_NE(a, sample_postures(m, scripts, 3, 8));
  // Candidates of one script differ (independent chains).
  EXPECT_NE(std::vector<float>(a.begin(), a.begin() + kPoseDim),
            std::vector<float>(a.begin() + kPoseDim, a.begin() + 2 * kPoseDim));
  // w = 0 is the unconditional model: both scripts give the same samples for the same noise rows.
  PostureSampleOptions o;
  o.guidance = 0.0;
  const auto u1 = sample_postures(m, {"both knees are straight."}, 1, 11, o);
  const auto u2 = sample_postures(m, {"the hands are close together."}, 1, 11, o);
  for (size_t i = 0; i < u1.size(); ++i) EXPECT_NEAR(u1[i], u2[i], 1e-5);
  EXPECT_THROW(sample_postures(m, {}, 1, 0), Error);
  EXPECT_THROW(sample_postures(m, scripts, 0, 0), Error);
  // Strided DDIM: all T steps with eta = 1 is the default DDPM; fewer steps give other, finite samples.
  PostureSampleOptions d;
  d.steps = (int)m.net->config().diffusion_steps;
  const auto full = sample_postures(m, scripts, 3, 7, d);
  for (size_t i = 0; i < a.size(); ++i) ASSERT_NEAR(full[i], a[i], 1e-4);
  d.steps = 5;
  const auto fast = sample_postures(m, scripts, 3, 7, d);
  for (float f : fast) ASSERT_TRUE(std::isfinite(f));
  EXPECT_NE(fast, a);
  d.steps = (int)m.net->config().diffusion_steps + 1;
  EXPECT_THROW(sample_postures(m, scripts, 1, 0, d), Error);
  d.steps = -1;
  EXPECT_THROW(sample_postures(m, scripts, 1, 0, d), Error);
}

TEST(PostureDiffuser, CheckpointRoundTrip) {
  const text::Tokenizer tok = script_tokenizer();
  Generator g(4);
  PostureModel m;
  m.net = std::make_shared<PostureDiffuser>(tiny_config(tok), g);
  m.net->eval();
  m.tokenizer = tok;
  m.stats.mean.assign(kPoseDim, 0.1f);
  m.stats.std.assign(kPoseDim, 1.5f);
  m.info = {{"note", "test"}};
  const fs::path dir = temp_dir("ckpt");
  save_posture_model(m, (dir / "p.t2mckpt").string());
  const PostureModel r = load_posture_model((dir / "p.t2mckpt").string());
  EXPECT_EQ(r.info["note"], "test");
  EXPECT_EQ(r.tokenizer.vocab(), tok.vocab());
  EXPECT_EQ(sample_postures(m, {"the torso is vertical."}, 2, 3), sample_postures(r, {"the torso is vertical."}, 2, 3));
  std::ofstream(dir / "bad.t2mckpt") << "not a checkpoint";
  EXPECT_THROW(load_posture_model((dir / "bad.t2mckpt").string()), Error);
  fs::remove_all(dir);
}

TEST(PostureDiffuser, OverfitsFourScriptsToTheirPoses) {
  t2m::set_num_threads(1);  // tiny matrices: threads only add barrier waits on a loaded machine
  const text::Tokenizer tok = script_tokenizer();
  PostureDiffuserConfig c = tiny_config(tok);
  c.cond_drop = 0.1;
  Generator g(1);
  PostureDiffuser net(c, g);
  const PostureTrainData data = tiny_data(tok, c.max_tokens);
  const double before = posture_eval_loss(net, data, 4, 9);
  const fs::path dir = temp_dir("overfit");
  PostureTrainConfig tc;
  tc.steps = 400;
  tc.batch = 16;
  tc.lr = 3e-3;
  tc.warmup = 10;
  tc.save_every = 1000;
  train_posture_diffuser(net, data, tc, {(dir / "s.t2mckpt").string(), (dir / "log.jsonl").string(), ""}, false);
  const double after = posture_eval_loss(net, data, 4, 9);
  EXPECT_LT(after, 0.2 * before) << before << " -> " << after;
  // Each script's samples land nearest to its own pose.
  PostureModel m;
  m.net = std::shared_ptr<PostureDiffuser>(&net, [](PostureDiffuser*) {});
  m.tokenizer = tok;
  m.stats.mean.assign(kPoseDim, 0.f);
  m.stats.std.assign(kPoseDim, 1.f);
  const std::vector<std::string> scripts = {"both elbows are straight.", "the left elbow is completely bent.",
                                            "both feet are off the ground.", "the hands are wide apart."};
  const auto s = sample_postures(m, scripts, 2, 5);
  const auto x = data.x0.to_vector<float>();
  int hits = 0;
  for (int i = 0; i < 8; ++i) {
    int best = -1;
    double bd = 1e30;
    for (int k = 0; k < 4; ++k) {
      double dist = 0;
      for (int d = 0; d < kPoseDim; ++d) {
        double e = s[(size_t)i * kPoseDim + d] - x[(size_t)k * kPoseDim + d];
        dist += e * e;
      }
      if (dist < bd) bd = dist, best = k;
    }
    hits += best == i / 2;
  }
  EXPECT_GE(hits, 7);
  fs::remove_all(dir);
}

TEST(PostureDiffuser, ResumedTrainingEqualsStraight) {
  const text::Tokenizer tok = script_tokenizer();
  const PostureDiffuserConfig c = tiny_config(tok);
  const PostureTrainData data = tiny_data(tok, c.max_tokens);
  PostureTrainConfig tc;
  tc.steps = 12;
  tc.batch = 4;
  tc.warmup = 2;
  tc.save_every = 100;
  const fs::path dir = temp_dir("resume");
  Generator g1(2), g2(2);
  PostureDiffuser a(c, g1), b(c, g2);
  train_posture_diffuser(a, data, tc, {(dir / "a.t2mckpt").string(), (dir / "a.jsonl").string(), ""}, false);
  PostureTrainConfig half = tc;
  half.stop_at = 5;
  const PostureTrainPaths pb{(dir / "b.t2mckpt").string(), (dir / "b.jsonl").string(), ""};
  EXPECT_EQ(train_posture_diffuser(b, data, half, pb, false).steps, 5);
  EXPECT_EQ(train_posture_diffuser(b, data, tc, pb, true).steps, 12);
  const auto pa = a.named_parameters(), pbp = b.named_parameters();
  for (size_t i = 0; i < pa.size(); ++i)
    EXPECT_EQ(pa[i].second.data().to_vector<float>(), pbp[i].second.data().to_vector<float>()) << pa[i].first;
  fs::remove_all(dir);
}

TEST(PostureDiffuser, BadInputThrows) {
  const text::Tokenizer tok = script_tokenizer();
  PostureDiffuserConfig c = tiny_config(tok);
  c.heads = 3;  // 64 not divisible by 3
  Generator g(0);
  EXPECT_THROW(PostureDiffuser(c, g), Error);
  c = tiny_config(tok);
  c.vocab = 0;
  EXPECT_THROW(PostureDiffuser(c, g), Error);
  PostureDiffuser net(tiny_config(tok), g);
  const PostureTrainData data = tiny_data(tok, 24);
  const ScriptContext ctx = net.encode(data.ids, data.mask);
  EXPECT_THROW(net.forward(ag::Variable(Tensor::zeros({4, 10})), Tensor::zeros({4}, DType::i64), ctx), Error);
  EXPECT_THROW(net.forward(ag::Variable(Tensor::zeros({3, kPoseDim})), Tensor::zeros({3}, DType::i64), ctx), Error);
  EXPECT_THROW(PostureDiffuserConfig::from_json({{"width", 64}}), Error);
  PostureTrainConfig tc;
  tc.warmup = tc.steps;
  EXPECT_THROW(tc.validate(), Error);
}

}  // namespace
