// test_casim_diffusion_model.cpp — the CASIM-MDM denoiser and its text-motion aligner: joint-sequence shapes and
// masks, padding invariance, the null condition, gradchecks, guided sampling = separate passes, checkpoint round
// trip, resumable training, and a tiny overfit per conditioning variant (cls, mhsa, mhca).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "autograd/gradcheck.h"
#include "autograd/no_grad.h"
#include "autograd/ops_reduce.h"
#include "models/casim/aligner.h"
#include "models/casim/diffusion_checkpoint.h"
#include "models/casim/diffusion_generate.h"
#include "models/casim/diffusion_sampler.h"
#include "models/casim/diffusion_train.h"
#include "models/data/captions.h"
#include "models/data/features.h"
#include "models/text/text_motion_model.h"
#include "nn/loss_regression.h"
#include "nn/optim_adamw.h"
#include "nn/train_log.h"
#include "tensor/ops.h"
#include "tests/test_tensor_util.h"
#include "test_scratch_dir.h"

using namespace t2m;
using namespace t2m::casim;
using t2m::testing::expect_error;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir(const std::string& name) {
  return t2m::test::scratch_dir(name);
}

DenoiserConfig tiny(Conditioning c, int64_t F = 5) {
  DenoiserConfig d;
  d.cond = c, d.feature_dim = F, d.width = 8, d.layers = 2, d.heads = 2, d.mlp_ratio = 2, d.freq_dim = 8;
  d.text_dim = 6, d.pooled_dim = 4, d.diffusion_steps = 50;
  return d;
}

DiffusionText random_text(int64_t B, int64_t L, Generator& g, DType dt = DType::f32) {
  DiffusionText t;
  t.tokens = rand_normal({B, L, 6}, g, 0, 1, dt);
  t.tok_mask = Tensor::ones({B, L});
  t.pooled = rand_normal({B, 4}, g, 0, 1, dt);
  return t;
}

const Conditioning kAll[3] = {Conditioning::cls, Conditioning::mhsa, Conditioning::mhca};

const std::vector<std::pair<std::string, std::string>> kLabels = {{"walk", "normal"}, {"run", "happy"}, {"walk", "sad"}};

text::RetrievalBundle text_bundle() {
  text::RetrievalBundle b;
  std::vector<std::string> corpus;
  for (const auto& [c, s] : kLabels)
    for (const auto& t : data::caption_paraphrases(c, s, 1, 8)) corpus.push_back(t);
  b.tokenizer = text::Tokenizer::build(corpus);
  text::TextMotionConfig c;
  c.text.vocab = b.tokenizer.vocab_size(), c.text.dim = 6, c.text.layers = 1, c.text.heads = 2, c.text.embed_dim = 4;
  c.text.max_len = 24;
  c.motion.dim = 8, c.motion.layers = 1, c.motion.heads = 2, c.motion.patch = 4, c.motion.max_patches = 4;
  c.motion.embed_dim = 4;
  Generator g(3);
  b.model = std::make_shared<text::TextMotionModel>(c, g);
  b.stats.mean.assign(data::kFeatureDim, 0.f);
  b.stats.std.assign(data::kFeatureDim, 1.f);
  b.window = 16;
  return b;
}

// Three smooth, distinct 16-frame clips of the real feature width.
std::vector<data::MotionClip> toy_clips() {
  std::vector<data::MotionClip> out;
  for (size_t i = 0; i < kLabels.size(); ++i) {
    data::MotionClip c;
    c.name = "dataset-2_" + kLabels[i].first + "_" + kLabels[i].second + "_00" + std::to_string(i + 1);
    c.content = kLabels[i].first, c.style = kLabels[i].second;
    c.frames = 16;
    for (int t = 0; t < c.frames; ++t)
      for (int d = 0; d < data::kFeatureDim; ++d)
        c.features.push_back(float(std::sin(0.4 * t + 0.05 * d + 2.0 * double(i)) + 0.5 * (double(i) - 1)));
    out.push_back(std::move(c));
  }
  return out;
}

data::FeatureStats unit_stats() {
  data::FeatureStats s;
  s.mean.assign(data::kFeatureDim, 0.f);
  s.std.assign(data::kFeatureDim, 1.f);
  return s;
}

}  // namespace

TEST(CasimAligner, JoinShapesMasksAndMotionPart) {
  Generator g(1);
  const ag::Variable text(rand_normal({2, 3, 4}, g)), motion(rand_normal({2, 5, 4}, g));
  Tensor tm = Tensor::ones({2, 3});
  tm.data<float>()[2] = 0;  // sample 0: 2 real words
  Tensor mm = Tensor::ones({2, 5});
  mm.data<float>()[9] = 0;  // sample 1: 4 real frames
  const JoinedSequence j = join_text_motion(text, tm, motion, mm);
  EXPECT_EQ(j.seq.data().shape(), (Shape{2, 8, 4}));
  EXPECT_EQ(j.mask.shape(), (Shape{2, 8}));
  EXPECT_EQ(j.text_len, 3);
  const std::vector<float> want = {1, 1, 0, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 0};
  for (int i = 0; i < 16; ++i) EXPECT_EQ(j.mask.data<float>()[i], want[(size_t)i]) << i;
  // text first, motion after: motion_part gives back the motion tokens exactly
  EXPECT_EQ(max_abs_diff(motion_part(j, j.seq).data(), motion.data()), 0.0);
  EXPECT_EQ(max_abs_diff(j.seq.data().narrow(1, 0, 3), text.data()), 0.0);
  // undefined masks = all real
  EXPECT_EQ(sum(join_text_motion(text, Tensor(), motion, Tensor()).mask).item(), 16.0);
  expect_error([&] { join_text_motion(text, tm, ag::Variable(rand_normal({2, 5, 3}, g)), mm); }, {"aligner"});
  expect_error([&] { join_text_motion(text, Tensor::ones({2, 4}), motion, mm); }, {"aligner", "text"});
}

TEST(CasimAligner, NullConditionReplacesDroppedRowsOnly) {
  Generator g(2);
  const ag::Variable text(rand_normal({3, 4, 5}, g));
  const ag::Variable null(rand_normal({5}, g));
  Tensor tm = Tensor::ones({3, 4});
  tm.data<float>()[3] = 0;
  const Tensor drop = Tensor::from_vector(std::vector<float>{0, 1, 0}, {3});
  const TextCondition c = with_null_condition(text, tm, null, drop);
  for (int64_t b : {0, 2}) {
    EXPECT_EQ(max_abs_diff(c.tokens.data().select(0, b), text.data().select(0, b)), 0.0);
    EXPECT_EQ(max_abs_diff(c.mask.select(0, b), tm.select(0, b)), 0.0);
  }
  EXPECT_EQ(max_abs_diff(c.tokens.data().select(0, 1).select(0, 0), null.data()), 0.0);
  EXPECT_EQ(c.mask.data<float>()[4], 1.f);
  for (int l = 1; l < 4; ++l) EXPECT_EQ(c.mask.data<float>()[4 + l], 0.f);
  // gradient: double-precision finite differences through both branches
  auto r = ag::gradcheck(
      [&](const std::vector<ag::Variable>& in) { return with_null_condition(in[0], tm, in[1], drop).tokens; },
      {rand_normal({3, 4, 5}, g, 0, 1, DType::f64), rand_normal({5}, g, 0, 1, DType::f64)});
  EXPECT_TRUE(r.ok) << r.message;
  expect_error([&] { with_null_condition(text, tm, ag::Variable(Tensor::zeros({4})), drop); }, {"null"});
  expect_error([&] { with_null_condition(text, tm, null, Tensor::zeros({2})); }, {"drop"});
}

TEST(CasimAligner, CrossBlockGradcheckAndTextPaddingInvariance) {
  Generator g(4);
  CrossAlignerBlock blk(CrossAlignerConfig{.dim = 4, .heads = 2, .mlp_ratio = 2}, g);
  blk.to(DType::f64);
  Tensor tm = Tensor::ones({1, 3});
  tm.data<float>()[2] = 0;
  auto r = ag::gradcheck(
      [&](const std::vector<ag::Variable>& in) { return blk.forward(in[0], Tensor(), in[1], tm); },
      {rand_normal({1, 3, 4}, g, 0, 1, DType::f64), rand_normal({1, 3, 4}, g, 0, 1, DType::f64)});
  EXPECT_TRUE(r.ok) << r.message;
  // A padded text token's value changes nothing.
  ag::NoGradGuard ng;
  const Tensor x = rand_normal({1, 3, 4}, g, 0, 1, DType::f64);
  Tensor y = rand_normal({1, 3, 4}, g, 0, 1, DType::f64);
  const Tensor a = blk.forward(ag::Variable(x), Tensor(), ag::Variable(y), tm).data();
  for (int k = 0; k < 4; ++k) y.data<double>()[8 + k] = 100.0 + k;
  const Tensor b = blk.forward(ag::Variable(x), Tensor(), ag::Variable(y), tm).data();
  EXPECT_LT(max_abs_diff(a, b), 1e-12);
}

TEST(CasimDenoiser, ShapesAndPaddingInvarianceForEveryVariant) {
  for (Conditioning c : kAll) {
    Generator g(5);
    CasimDenoiser m(tiny(c), g);
    m.eval();
    ag::NoGradGuard ng;
    const DiffusionText t0 = random_text(2, 4, g);
    DiffusionText t1 = t0;
    t1.tok_mask = Tensor::ones({2, 4});
    t1.tok_mask.data<float>()[3] = 0;  // sample 0 has 3 words
    Tensor fm = Tensor::ones({2, 6});
    fm.data<float>()[5] = 0;  // sample 0 has 5 frames
    const Tensor x = rand_normal({2, 6, 5}, g);
    const Tensor t = Tensor::from_vector(std::vector<int64_t>{3, 40}, {2});
    const Tensor a = m.forward(ag::Variable(x), t, t1, Tensor(), fm).data();
    ASSERT_EQ(a.shape(), (Shape{2, 6, 5})) << conditioning_name(c);
    // padding contents: the padded word and the padded frame of sample 0
    DiffusionText t2 = t1;
    t2.tokens = t1.tokens.clone();
    for (int k = 0; k < 6; ++k) t2.tokens.data<float>()[3 * 6 + k] = 50.f;
    Tensor x2 = x.clone();
    for (int k = 0; k < 5; ++k) x2.data<float>()[5 * 5 + k] = -30.f;
    const Tensor b = m.forward(ag::Variable(x2), t, t2, Tensor(), fm).data();
    EXPECT_LT(max_abs_diff(a.narrow(1, 0, 5).select(0, 0), b.narrow(1, 0, 5).select(0, 0)), 1e-5)
        << conditioning_name(c);
    EXPECT_LT(max_abs_diff(a.select(0, 1), b.select(0, 1)), 1e-5) << conditioning_name(c);
    // padding amount: sample 1 alone with its own length gives the same output
    DiffusionText s1;
    s1.tokens = t1.tokens.narrow(0, 1, 1).contiguous(), s1.tok_mask = t1.tok_mask.narrow(0, 1, 1).contiguous();
    s1.pooled = t1.pooled.narrow(0, 1, 1).contiguous();
    const Tensor solo = m.forward(ag::Variable(x.narrow(0, 1, 1).contiguous()), t.narrow(0, 1, 1).contiguous(), s1).data();
    EXPECT_LT(max_abs_diff(solo.select(0, 0), a.select(0, 1)), 1e-5) << conditioning_name(c);
    // text matters when kept, and not at all when dropped
    DiffusionText t3 = t1;
    t3.tokens = rand_normal({2, 4, 6}, g), t3.pooled = rand_normal({2, 4}, g);
    const Tensor drop = Tensor::ones({2});
    EXPECT_GT(max_abs_diff(m.forward(ag::Variable(x), t, t3, Tensor(), fm).data(), a), 1e-4) << conditioning_name(c);
    EXPECT_LT(max_abs_diff(m.forward(ag::Variable(x), t, t3, drop, fm).data(), m.forward(ag::Variable(x), t, t1, drop, fm).data()),
              1e-6)
        << conditioning_name(c);
    // errors
    expect_error([&] { m.forward(ag::Variable(rand_normal({2, 6, 4}, g)), t, t1); }, {"CasimDenoiser", "x_t"});
    expect_error([&] { m.forward(ag::Variable(x), Tensor::from_vector(std::vector<int64_t>{3, 50}, {2}), t1); },
                 {"CasimDenoiser", "50"});
    expect_error([&] { m.forward(ag::Variable(x), t, t1, Tensor(), Tensor::ones({2, 5})); }, {"frame_mask"});
  }
}

TEST(CasimDenoiser, GradcheckEveryVariant) {
  for (Conditioning c : kAll) {
    Generator g(6);
    DenoiserConfig cfg = tiny(c, 3);
    cfg.width = 4, cfg.layers = 1, cfg.freq_dim = 4;
    CasimDenoiser m(cfg, g);
    m.to(DType::f64);
    const DiffusionText txt = random_text(1, 2, g, DType::f64);
    const Tensor t = Tensor::from_vector(std::vector<int64_t>{7}, {1});
    auto r = ag::gradcheck([&](const std::vector<ag::Variable>& in) { return m.forward(in[0], t, txt); },
                           {rand_normal({1, 3, 3}, g, 0, 1, DType::f64)});
    EXPECT_TRUE(r.ok) << conditioning_name(c) << ": " << r.message;
  }
}

TEST(CasimDenoiser, ConfigJsonRoundTripAndErrors) {
  const DenoiserConfig c = tiny(Conditioning::mhca);
  const DenoiserConfig d = DenoiserConfig::from_json(c.to_json());
  EXPECT_EQ(d.to_json(), c.to_json());
  nlohmann::json j = c.to_json();
  j["bogus"] = 1;
  expect_error([&] { DenoiserConfig::from_json(j); }, {"unknown", "bogus"});
  j = c.to_json();
  j["cond"] = "film";
  expect_error([&] { DenoiserConfig::from_json(j); }, {"film"});
  j = c.to_json();
  j["heads"] = 3;
  expect_error([&] { DenoiserConfig::from_json(j); }, {"bad config"});
}

TEST(CasimSampler, GuidedSamplingEqualsSeparatePasses) {
  Generator g(7);
  CasimDenoiser m(tiny(Conditioning::mhsa), g);
  m.eval();
  const DiffusionSchedule sch = cosine_schedule(50);
  const DiffusionText txt = random_text(2, 3, g);
  const Tensor fm = Tensor::ones({2, 4});
  for (double w : {1.0, 2.5}) {
    SamplerOptions o;
    o.steps = 5, o.guidance = w, o.eta = 1.0;
    Generator a(42), b(42);
    const Tensor got = sample_motions(m, sch, txt, fm, 4, o, a);
    ag::NoGradGuard ng;
    const X0Predictor fn = [&](const Tensor& x, int64_t t) {
      const Tensor tt = Tensor::full({2}, double(t), DType::i64);
      const Tensor c = m.forward(ag::Variable(x), tt, txt, Tensor::zeros({2}), fm).data();
      const Tensor u = m.forward(ag::Variable(x), tt, txt, Tensor::ones({2}), fm).data();
      return guided_x0(c, u, w);
    };
    const Tensor xT = rand_normal({2, 4, 5}, b);
    const Tensor want = diffusion_sample(sch, fn, xT, o, b);
    EXPECT_LT(max_abs_diff(got, want), 1e-5) << w;
  }
}

TEST(CasimCheckpoint, RoundTripAndBadFiles) {
  const fs::path d = temp_dir("ckpt");
  Generator g(8);
  DiffusionBundle b;
  b.model = std::make_shared<CasimDenoiser>(tiny(Conditioning::cls), g);
  b.stats.mean.assign(5, 0.5f), b.stats.std.assign(5, 2.f);
  b.window = 12, b.sampler.steps = 7, b.sampler.guidance = 1.5;
  b.train = {{"steps", 3}};
  save_diffusion_checkpoint(b, (d / "a.t2mckpt").string());
  const DiffusionBundle l = load_diffusion_checkpoint((d / "a.t2mckpt").string());
  EXPECT_EQ(l.model->config().to_json(), b.model->config().to_json());
  EXPECT_EQ(l.window, 12);
  EXPECT_EQ(l.sampler.steps, 7);
  EXPECT_EQ(l.sampler.guidance, 1.5);
  EXPECT_EQ(l.stats.std[2], 2.f);
  const auto pa = b.model->named_parameters(), pb = l.model->named_parameters();
  ASSERT_EQ(pa.size(), pb.size());
  for (size_t i = 0; i < pa.size(); ++i) EXPECT_EQ(max_abs_diff(pa[i].second.data(), pb[i].second.data()), 0.0);
  expect_error([&] { load_diffusion_checkpoint((d / "missing.t2mckpt").string()); }, {"missing.t2mckpt"});
  nn::Checkpoint other;
  other.meta = {{"format", "t2m-gen-1"}};
  other.save((d / "other.t2mckpt").string());
  expect_error([&] { load_diffusion_checkpoint((d / "other.t2mckpt").string()); }, {"other.t2mckpt", "format"});
}

TEST(CasimTrain, StopResumeEqualsStraightRun) {
  const auto clips = toy_clips();
  const auto tb = text_bundle();
  DiffusionTrainConfig cfg;
  cfg.steps = 6, cfg.batch = 2, cfg.window = 12, cfg.lr = 1e-3, cfg.warmup = 1, cfg.save_every = 2, cfg.seed = 3;
  auto run = [&](const std::string& name, int64_t stop_at, bool resume, CasimDenoiser& m) {
    const fs::path dir = t2m::test::scratch_root() / name;
    DiffusionTrainConfig c = cfg;
    c.stop_at = stop_at;
    DiffusionTrainPaths p{(dir / "state.t2mckpt").string(), (dir / "log.jsonl").string(), (dir / "loss.svg").string()};
    return train_diffusion(m, tb, clips, unit_stats(), c, p, resume, "test");
  };
  temp_dir("straight"), temp_dir("chunked");
  DenoiserConfig dc = tiny(Conditioning::mhsa, data::kFeatureDim);
  Generator g1(9), g2(9), g3(9);
  CasimDenoiser a(dc, g1), b1(dc, g2), b2(dc, g3);
  EXPECT_EQ(run("straight", 0, false, a).steps, 6);
  EXPECT_EQ(run("chunked", 4, false, b1).steps, 4);  // crosses an epoch boundary (3 clips, batch 2, drop_last)
  EXPECT_EQ(run("chunked", 0, true, b2).steps, 6);
  const auto pa = a.named_parameters(), pb = b2.named_parameters();
  for (size_t i = 0; i < pa.size(); ++i)
    EXPECT_EQ(max_abs_diff(pa[i].second.data(), pb[i].second.data()), 0.0) << pa[i].first;
  cfg.lr = 5e-4;  // another config is refused
  Generator g4(9);
  CasimDenoiser b3(dc, g4);
  expect_error([&] { run("chunked", 0, true, b3); }, {"config"});
  cfg = DiffusionTrainConfig{};
  cfg.warmup = cfg.steps;
  expect_error([&] { cfg.validate(); }, {"casim train", "bad config"});
}

// Each variant memorises three captioned clips: the x0 loss (MDM Eq 2, random t) falls by a large factor, and
// sampling from pure noise with a clip's text lands on that clip (so the text is used, not only the noisy input).
TEST(CasimTrain, EveryVariantOverfitsThreeClips) {
  const int64_t B = 3, T = 8, F = 6;
  Generator dg(12);
  const Tensor x0 = rand_normal({B, T, F}, dg);
  const DiffusionText txt = random_text(B, 3, dg);
  const DiffusionSchedule sch = cosine_schedule(50);
  for (Conditioning c : kAll) {
    DenoiserConfig dc = tiny(c, F);
    dc.width = 32, dc.heads = 4, dc.cond_dropout = 0.0;
    Generator g(10);
    CasimDenoiser m(dc, g);
    nn::AdamWOptions ao;
    ao.lr = 3e-3;
    const auto params = m.named_parameters();
    nn::AdamW opt(params, ao);
    Generator rng(4);
    double first = 0, last = 0;
    const int steps = 400;
    for (int s = 0; s < steps; ++s) {
      opt.zero_grad();
      const Tensor t = randint({B}, rng, 0, sch.steps);
      const Tensor xt = q_sample(sch, x0, t, rand_normal({B, T, F}, rng));
      ag::Variable loss = nn::mse_loss(m.forward(ag::Variable(xt), t, txt), ag::Variable(x0));
      loss.backward();
      opt.step();
      if (s < 20) first += loss.item() / 20;
      if (s >= steps - 40) last += loss.item() / 40;
    }
    EXPECT_LT(last, first / 10) << conditioning_name(c) << " first " << first << " last " << last;
    m.eval();
    SamplerOptions o;
    o.steps = 10, o.guidance = 1.0;
    Generator sg(5);
    const Tensor gen = sample_motions(m, sch, txt, Tensor(), T, o, sg);
    for (int64_t k = 0; k < B; ++k) {
      double best = 1e30;
      int64_t arg = -1;
      for (int64_t j = 0; j < B; ++j) {
        const double e = max_abs_diff(gen.select(0, k), x0.select(0, j));
        if (e < best) best = e, arg = j;
      }
      EXPECT_EQ(arg, k) << conditioning_name(c);
      EXPECT_LT(best, 0.5) << conditioning_name(c);
    }
  }
}
