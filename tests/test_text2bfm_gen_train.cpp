// test_text2bfm_gen_train.cpp — the generator's training data (VBB posterior means, standardisation, batches) and
// the resumable Eq 15 training loop (`t2m train gen`) on tiny random data; the gen checkpoint round trip.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>

#include "models/text2bfm/gen_train.h"
#include "models/text2bfm/pipeline_checkpoints.h"
#include "models/text2bfm/program_dataset.h"
#include "nn/checkpoint.h"
#include "nn/train_log.h"

using namespace t2m;
using namespace t2m::text2bfm;
namespace fs = std::filesystem;

namespace {

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("t2m_gentrain_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

VbbConfig tiny_vbb() {
  VbbConfig c;
  c.in_dim = 6, c.width = 8, c.latent = 3, c.levels = 2, c.depth = 1, c.groups = 4;
  return c;
}

FlowGeneratorConfig tiny_gen() {
  FlowGeneratorConfig c;
  c.latent = 3, c.width = 16, c.depth = 1, c.heads = 2, c.ctx_dim = 8, c.freq_dim = 8;
  c.adapter = {.tok_dim = 5, .width = 8, .depth = 1, .heads = 2, .ctx_dim = 8, .max_len = 6};
  return c;
}

// 3 clips of policy latents (lengths 9, 16, 4), 2 captions each, random token features.
ProgramDataset tiny_data(const Vbb& vbb) {
  Generator g(5);
  std::vector<Tensor> z = {rand_normal({9, 6}, g), rand_normal({16, 6}, g), rand_normal({4, 6}, g)};
  auto progs = encode_programs(vbb, z);
  Tensor tok = rand_normal({6, 6, 5}, g), mask = Tensor::ones({6, 6});
  for (int64_t i = 0; i < 6; ++i)
    for (int64_t k = 3 + i % 3; k < 6; ++k) mask.set({i, k}, 0);
  return make_program_dataset(progs, {{0, 1}, {2, 3}, {4, 5}}, tok, mask, 3);
}

// tiny_data through a fresh tiny VBB (seed 1), the training tests' data.
ProgramDataset tiny_data_of_a_tiny_vbb() {
  Generator g(1);
  Vbb vbb(tiny_vbb(), g);
  vbb.eval();
  return tiny_data(vbb);
}

// A run's state, log and plot files in dir, named n.ckpt / n.jsonl / n.svg.
GenTrainPaths run_paths(const fs::path& dir, const std::string& n) {
  return GenTrainPaths{(dir / (n + ".ckpt")).string(), (dir / (n + ".jsonl")).string(), (dir / (n + ".svg")).string()};
}

}  // namespace

TEST(ProgramDataset, PosteriorMeansStandardisedAndBatches) {
  Generator g(1);
  Vbb vbb(tiny_vbb(), g);
  vbb.eval();
  Generator g2(5);
  const Tensor z0 = rand_normal({9, 6}, g2);
  const auto p = encode_programs(vbb, {z0});
  ASSERT_EQ(p[0].shape(), (Shape{3, 3}));  // ceil(9 / 4) program frames
  // Right padding repeats the last latent: the same as encoding the explicitly padded clip.
  Tensor zp = Tensor::empty({12, 6});
  for (int64_t t = 0; t < 12; ++t)
    for (int64_t k = 0; k < 6; ++k) zp.set({t, k}, z0.at({std::min<int64_t>(t, 8), k}));
  EXPECT_EQ(p[0].to_vector<float>(), encode_programs(vbb, {zp})[0].to_vector<float>());

  const ProgramDataset d = tiny_data(vbb);
  // Standardised over all program frames: mean 0, std ~1 per channel.
  for (int64_t k = 0; k < 3; ++k) {
    double s = 0, s2 = 0, n = 0;
    for (const auto& m : d.programs)
      for (int64_t t = 0; t < m.size(0); ++t, n += 1) s += m.at({t, k}), s2 += m.at({t, k}) * m.at({t, k});
    EXPECT_NEAR(s / n, 0.0, 1e-5);
    EXPECT_NEAR(std::sqrt(s2 / n), 1.0, 1e-3);
  }
  Generator r(3), r2(3);
  const ProgramBatch b = sample_program_batch(d, 8, r), b2 = sample_program_batch(d, 8, r2);
  EXPECT_EQ(b.m.shape(), (Shape{8, 3, 3}));
  EXPECT_EQ(b.tokens.shape(), (Shape{8, 6, 5}));
  EXPECT_EQ(b.m.to_vector<float>(), b2.m.to_vector<float>());  // deterministic in the rng
  for (int64_t i = 0; i < 8; ++i) {  // the 1-frame clip (Tz 4) is padded with mask 0
    double real = 0;
    for (int64_t t = 0; t < 3; ++t) real += b.m_mask.at({i, t});
    EXPECT_TRUE(real == 1 || real == 3 || real == 2) << real;
    for (int64_t t = (int64_t)real; t < 3; ++t) EXPECT_EQ(b.m.at({i, t, 0}), 0.f);
  }
  EXPECT_THROW(make_program_dataset({}, {}, Tensor::zeros({1, 1, 1}), Tensor::ones({1, 1}), 2), Error);
  EXPECT_THROW(encode_programs(vbb, {Tensor::zeros({5, 7})}), Error);
  EXPECT_THROW(make_program_dataset(encode_programs(vbb, {z0}), {{7}}, Tensor::zeros({1, 2, 5}),
                                    Tensor::ones({1, 2}), 2), Error);  // caption row out of range
}

TEST(GenTrain, LossFallsAndResumeIsBitIdentical) {
  const ProgramDataset d = tiny_data_of_a_tiny_vbb();
  GenTrainConfig cfg;
  cfg.steps = 200, cfg.batch = 16, cfg.lr = 1e-2, cfg.warmup = 5, cfg.save_every = 10;
  const fs::path dir = fresh_dir("resume");
  auto paths = [&](const std::string& n) { return run_paths(dir, n); };
  Generator ga(7), gb(7);
  auto straight_p = std::make_shared<FlowGenerator>(tiny_gen(), ga);
  FlowGenerator& straight = *straight_p;
  FlowGenerator chunked(tiny_gen(), gb);
  const auto r = train_generator(straight, d, cfg, paths("a"), false);
  EXPECT_EQ(r.steps, 200);
  auto c1 = cfg;
  c1.stop_at = 85;
  EXPECT_EQ(train_generator(chunked, d, c1, paths("b"), false).steps, 85);
  Generator gc(99);  // a fresh process: other initial weights, everything comes from the state file
  FlowGenerator resumed(tiny_gen(), gc);
  EXPECT_EQ(train_generator(resumed, d, cfg, paths("b"), true).steps, 200);
  const auto pa = straight.named_parameters(), pb = resumed.named_parameters();
  for (size_t i = 0; i < pa.size(); ++i)
    ASSERT_EQ(pa[i].second.data().to_vector<float>(), pb[i].second.data().to_vector<float>()) << pa[i].first;
  // The log has one record per step (the resumed run dropped nothing, duplicated nothing); the loss falls.
  const auto log = nn::read_train_log(paths("b").log);
  ASSERT_EQ(log.size(), 200u);
  double first = 0, last = 0;
  for (int i = 0; i < 20; ++i) first += log[i]["loss"].get<double>(), last += log[180 + i]["loss"].get<double>();
  std::printf("loss first 20 steps %.3f, last 20 %.3f\n", first / 20, last / 20);
  EXPECT_LT(last, 0.8 * first);
  EXPECT_TRUE(fs::exists(paths("a").svg));

  // Checkpoint round trip: same velocities, stats kept; a corrupted stat is refused.
  GenBundle b;
  b.model = straight_p;
  b.program_mean = d.mean, b.program_std = d.std, b.compression = 4, b.window = 3;
  const std::string path = (dir / "gen.t2mckpt").string();
  save_gen_checkpoint(b, path);
  const GenBundle l = load_gen_checkpoint(path);
  EXPECT_EQ(l.compression, 4);
  EXPECT_EQ(l.program_std.to_vector<float>(), d.std.to_vector<float>());
  const auto la = b.model->named_parameters(), lb = l.model->named_parameters();
  ASSERT_EQ(la.size(), lb.size());
  for (size_t i = 0; i < la.size(); ++i)
    EXPECT_EQ(la[i].second.data().to_vector<float>(), lb[i].second.data().to_vector<float>());
  b.program_std = Tensor::zeros({3});
  save_gen_checkpoint(b, path);
  EXPECT_THROW(load_gen_checkpoint(path), Error);
  EXPECT_THROW(load_gen_checkpoint((dir / "none.t2mckpt").string()), Error);
  fs::remove_all(dir);
}

// --ema: the checkpointed generator holds the moving average of the weights after each step (Ema's warm-up decay
// min(d, (1 + t) / (10 + t))), recomputed here by hand from a run without EMA stopped after every step; training
// itself is unchanged (the state file holds the same training values as the run without EMA); resuming an EMA run
// gives the same averaged weights as an uninterrupted one.
TEST(GenTrain, EmaHoldsTheAveragedWeightsAndResumes) {
  const ProgramDataset d = tiny_data_of_a_tiny_vbb();
  GenTrainConfig cfg;
  cfg.steps = 12, cfg.batch = 8, cfg.lr = 1e-2, cfg.warmup = 2, cfg.save_every = 100;
  const fs::path dir = fresh_dir("ema");
  auto paths = [&](const std::string& n) { return run_paths(dir, n); };
  // Without EMA, one step per chunk: the weights after every step, averaged by hand in double.
  Generator g0(7);
  FlowGenerator plain(tiny_gen(), g0);
  std::vector<std::vector<double>> avg;
  for (const auto& [name, p] : plain.named_parameters()) {
    const auto v = p.data().to_vector<float>();
    avg.emplace_back(v.begin(), v.end());  // the shadow starts at the initial weights
  }
  const double decay = 0.9;
  for (int64_t s = 1; s <= cfg.steps; ++s) {
    auto c = cfg;
    c.stop_at = s;
    train_generator(plain, d, c, paths("plain"), s > 1);
    const double dt = std::min(decay, double(s) / double(9 + s));  // t = s - 1 updates before this one
    const auto ps = plain.named_parameters();
    for (size_t i = 0; i < ps.size(); ++i) {
      const auto v = ps[i].second.data().to_vector<float>();
      for (size_t k = 0; k < v.size(); ++k) avg[i][k] = float(dt * avg[i][k] + (1 - dt) * double(v[k]));
    }
  }
  auto ce = cfg;
  ce.ema = decay;
  Generator g1(7);
  FlowGenerator averaged(tiny_gen(), g1);
  EXPECT_EQ(train_generator(averaged, d, ce, paths("ema"), false).steps, cfg.steps);
  const auto pa = averaged.named_parameters(), pp = plain.named_parameters();
  const nn::Checkpoint state = nn::Checkpoint::load(paths("ema").state);
  double moved = 0;
  for (size_t i = 0; i < pa.size(); ++i) {
    const auto a = pa[i].second.data().to_vector<float>(), p = pp[i].second.data().to_vector<float>();
    EXPECT_EQ(state.get("model." + pa[i].first).to_vector<float>(), p) << pa[i].first;  // training unchanged
    for (size_t k = 0; k < a.size(); ++k) {
      ASSERT_NEAR(a[k], avg[i][k], 1e-6 + 1e-5 * std::fabs(avg[i][k])) << pa[i].first << " " << k;
      moved = std::max(moved, double(std::fabs(a[k] - p[k])));
    }
  }
  EXPECT_GT(moved, 1e-3);  // the average is not the final weights
  // Chunked with EMA (stop at 5, resume in a fresh generator) = uninterrupted, bit for bit.
  auto c5 = ce;
  c5.stop_at = 5;
  Generator g2(7), g3(42);
  FlowGenerator first(tiny_gen(), g2), resumed(tiny_gen(), g3);
  train_generator(first, d, c5, paths("ema_chunked"), false);
  train_generator(resumed, d, ce, paths("ema_chunked"), true);
  const auto pr = resumed.named_parameters();
  for (size_t i = 0; i < pa.size(); ++i)
    ASSERT_EQ(pr[i].second.data().to_vector<float>(), pa[i].second.data().to_vector<float>()) << pa[i].first;
  // A resumed run must agree on the EMA setting; bad decays are refused.
  Generator g4(7);
  FlowGenerator other(tiny_gen(), g4);
  EXPECT_THROW(train_generator(other, d, cfg, paths("ema_chunked"), true), Error);
  for (double bad : {-0.1, 1.0, std::nan("")}) {
    auto cb = cfg;
    cb.ema = bad;
    EXPECT_THROW(cb.validate(), Error) << bad;
  }
  fs::remove_all(dir);
}
