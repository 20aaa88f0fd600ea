// test_vbb_train.cpp — the VBB training pipeline on a tiny BFM and synthetic clips: Eq 2 latent cache (rows match
// infer_tracking_z, invalidation when the BFM file changes, bad files), the windowed Table 4 scores, the VBB
// checkpoint (round trip, bad files), bit-identical resume of a training run, and a tiny overfit of the whole loop.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "models/bfm/policy_checkpoint.h"
#include "models/data/captions.h"
#include "models/text2bfm/latent_cache.h"
#include "models/text2bfm/vbb_checkpoint.h"
#include "models/text2bfm/vbb_eval.h"
#include "models/text2bfm/vbb_trainer.h"
#include "nn/checkpoint.h"
#include "tensor/ops.h"
#include "test_scratch_dir.h"

using namespace t2m;
using namespace t2m::text2bfm;
namespace fs = std::filesystem;

namespace {

std::string tmp_dir(const std::string& name) {
  return t2m::test::scratch_dir(name).string();
}

template <typename F>
void expect_error(F f, const std::vector<std::string>& parts) {
  try {
    f();
    FAIL() << "no error";
  } catch (const Error& e) {
    for (const auto& p : parts) EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << e.what() << " / " << p;
  }
}

bfm::FbConfig tiny_fb() {
  bfm::FbConfig c;
  c.obs_dim = 6;
  c.action_dim = 3;
  c.z_dim = 8;
  c.hidden = 16;
  c.b_hidden = 16;
  c.track_window = 3;
  return c;
}

// A smooth synthetic state sequence [T, 6].
Tensor clip_states(int T, double phase) {
  std::vector<float> v;
  for (int t = 0; t < T; ++t)
    for (int k = 0; k < 6; ++k) v.push_back((float)std::sin(0.3 * t + phase + k));
  return Tensor::from_vector(v, {T, 6});
}

LatentSet toy_set(bfm::FbAgent& agent, const std::string& checksum, const std::vector<int>& lengths) {
  LatentSet s;
  s.split = "train";
  s.bfm_checksum = checksum;
  s.window = agent.config().track_window;
  const auto& contents = data::caption_contents();
  const auto& styles = data::caption_styles();
  for (size_t i = 0; i < lengths.size(); ++i)
    s.add_clip(agent, "clip" + std::to_string(i), contents[i % contents.size()].label,
               styles[(i / 2) % styles.size()].label, clip_states(lengths[i], 0.7 * (double)i));
  return s;
}

// Toy frozen "text encoder": per word a fixed pseudo-random 12-d vector (hash of the word), K = longest caption.
TokenFeatures toy_text(const std::vector<std::string>& captions) {
  std::vector<std::vector<std::string>> words;
  size_t K = 1;
  for (const auto& c : captions) {
    std::vector<std::string> w;
    std::string cur;
    for (char ch : c + " ")
      if (ch == ' ' || ch == ',') {
        if (!cur.empty()) w.push_back(cur);
        cur.clear();
      } else {
        cur += ch;
      }
    K = std::max(K, w.size());
    words.push_back(w);
  }
  const int64_t B = (int64_t)captions.size(), D = 12;
  Tensor tok = Tensor::zeros({B, (int64_t)K, D}), mask = Tensor::zeros({B, (int64_t)K});
  for (int64_t b = 0; b < B; ++b)
    for (size_t k = 0; k < words[b].size(); ++k) {
      const uint64_t h = std::hash<std::string>()(words[b][k]);
      for (int64_t j = 0; j < D; ++j) tok.data<float>()[(b * (int64_t)K + (int64_t)k) * D + j] = (float)std::sin(h % 1000 + 1.7 * j);
      mask.data<float>()[b * (int64_t)K + (int64_t)k] = 1.f;
    }
  return {tok, mask};
}

VbbTrainConfig tiny_train(int64_t steps) {
  VbbTrainConfig c;
  c.vbb.in_dim = 8;
  c.vbb.width = 16;
  c.vbb.latent = 4;
  c.vbb.levels = 1;
  c.vbb.depth = 1;
  c.vbb.groups = 4;
  c.batch = 4;
  c.window = 8;
  c.steps = steps;
  c.warmup = 2;
  c.lr = 3e-3;
  c.sem_dim = 8;
  c.seed = 5;
  return c;
}

std::vector<float> flat_params(const VbbTrainer& t, const nn::Module& m) {
  (void)t;
  std::vector<float> v;
  for (const auto& [n, p] : m.named_parameters()) {
    const Tensor c = p.data().contiguous();
    v.insert(v.end(), c.data<float>(), c.data<float>() + c.numel());
  }
  return v;
}

}  // namespace

TEST(LatentCache, RowsAreEq2LatentsWithTheirStates) {
  bfm::FbAgent agent(tiny_fb(), 1);
  const LatentSet s = toy_set(agent, "00000000", {5, 9});
  ASSERT_EQ(s.clips(), 2);
  EXPECT_EQ(s.frames(0), 4);  // T - 1 latents
  EXPECT_EQ(s.frames(1), 8);
  const Tensor st = clip_states(9, 0.7);
  const Tensor z = agent.infer_tracking_z(st, 3).contiguous();
  for (int64_t t = 0; t < 8; ++t)
    for (int64_t k = 0; k < 8; ++k) {
      EXPECT_EQ(s.z_at(1, t)[k], z.data<float>()[t * 8 + k]);
      if (k < 6) {
        EXPECT_EQ(s.state_at(1, t)[k], st.data<float>()[t * 6 + k]);
      }
    }
  double norm = 0;
  for (int k = 0; k < 8; ++k) norm += (double)s.z_at(0, 2)[k] * s.z_at(0, 2)[k];
  EXPECT_NEAR(norm, 8.0, 1e-4);  // radius sqrt(d)
  LatentSet bad;
  expect_error([&] { bad.add_clip(agent, "x", "walk", "normal", clip_states(1, 0)); }, {"latent cache", "T >= 2"});
}

TEST(LatentCache, InvalidatedWhenTheBfmChanges) {
  const std::string dir = tmp_dir("invalidate");
  bfm::FbAgent a(tiny_fb(), 1), b(tiny_fb(), 2);
  bfm::save_policy(a, dir + "/bfm.t2mckpt");
  const std::string ca = file_checksum(dir + "/bfm.t2mckpt");
  int builds = 0;
  bool rebuilt = false;
  const std::string path = dir + "/latents/train.t2mckpt";
  auto build_with = [&](bfm::FbAgent& ag, const std::string& crc) {
    return [&ag, &builds, crc] { ++builds; return toy_set(ag, crc, {6, 10}); };
  };
  const LatentSet s1 = ensure_latent_cache(path, ca, 3, build_with(a, ca), &rebuilt);
  EXPECT_TRUE(rebuilt);
  EXPECT_EQ(builds, 1);
  const LatentSet s2 = ensure_latent_cache(path, ca, 3, build_with(a, ca), &rebuilt);  // cached
  EXPECT_FALSE(rebuilt);
  EXPECT_EQ(builds, 1);
  EXPECT_EQ(s2.z, s1.z);
  EXPECT_EQ(s2.states, s1.states);
  EXPECT_EQ(s2.names, s1.names);
  EXPECT_EQ(s2.content, s1.content);
  // Another BFM file -> another checksum -> the cache is rebuilt with the new B.
  bfm::save_policy(b, dir + "/bfm.t2mckpt");
  const std::string cb = file_checksum(dir + "/bfm.t2mckpt");
  ASSERT_NE(ca, cb);
  const LatentSet s3 = ensure_latent_cache(path, cb, 3, build_with(b, cb), &rebuilt);
  EXPECT_TRUE(rebuilt);
  EXPECT_EQ(builds, 2);
  EXPECT_NE(s3.z, s1.z);
  EXPECT_EQ(load_latent_set(path).bfm_checksum, cb);
  // The same call loads again; a build that reports another checksum than asked for is refused.
  ensure_latent_cache(path, cb, 3, build_with(b, cb), &rebuilt);
  EXPECT_FALSE(rebuilt);
  expect_error([&] { ensure_latent_cache(path, "deadbeef", 3, build_with(b, cb)); }, {"expected deadbeef"});
}

TEST(LatentCache, BadFilesAreRefusedAndKept) {
  const std::string dir = tmp_dir("bad");
  bfm::FbAgent a(tiny_fb(), 1);
  const LatentSet s = toy_set(a, "0badf00d", {6, 10});
  const std::string path = dir + "/train.t2mckpt";
  save_latent_set(s, path);
  const LatentSet r = load_latent_set(path);
  EXPECT_EQ(r.z, s.z);
  EXPECT_EQ(r.offset, s.offset);
  EXPECT_EQ(r.window, 3);
  expect_error([&] { load_latent_set(dir + "/missing.t2mckpt"); }, {"missing.t2mckpt"});
  expect_error([&] { file_checksum(dir + "/missing.t2mckpt"); }, {"missing.t2mckpt"});
  // Truncated: the checkpoint layer refuses it; ensure_latent_cache neither rebuilds nor overwrites it.
  std::string bytes;
  {
    std::ifstream f(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(f), {});
  }
  const std::string cut = dir + "/cut.t2mckpt";
  std::ofstream(cut, std::ios::binary).write(bytes.data(), (std::streamsize)bytes.size() / 2);
  int builds = 0;
  expect_error([&] { ensure_latent_cache(cut, "0badf00d", 3, [&] { ++builds; return s; }); },
               {"cut.t2mckpt", "remove the file"});
  EXPECT_EQ(builds, 0);
  EXPECT_EQ(fs::file_size(cut), bytes.size() / 2);
  // A valid checkpoint of another kind.
  nn::Checkpoint other;
  other.meta = {{"format", "t2m-vbb-1"}};
  other.put("z", Tensor::zeros({2, 2}));
  other.save(dir + "/other.t2mckpt");
  expect_error([&] { load_latent_set(dir + "/other.t2mckpt"); }, {"not a latent cache"});
  // Inconsistent contents: offsets that do not cover the rows, labels missing, a non-finite latent.
  LatentSet off = s;
  off.offset.back() += 1;
  expect_error([&] { save_latent_set(off, dir + "/off.t2mckpt"); }, {"offsets say"});
  EXPECT_FALSE(fs::exists(dir + "/off.t2mckpt"));
  LatentSet lab = s;
  lab.style.pop_back();
  expect_error([&] { save_latent_set(lab, dir + "/lab.t2mckpt"); }, {"label count"});
  nn::Checkpoint hand = nn::Checkpoint::load(path);
  hand.put("offset", Tensor::from_vector(std::vector<int64_t>{0, 5, 4}, {3}));
  hand.save(dir + "/hand.t2mckpt");
  expect_error([&] { load_latent_set(dir + "/hand.t2mckpt"); }, {"hand.t2mckpt", "offsets must increase"});
  hand = nn::Checkpoint::load(path);
  Tensor z = hand.get("z").contiguous().clone();
  z.data<float>()[3] = NAN;
  hand.put("z", z);
  hand.save(dir + "/nan.t2mckpt");
  expect_error([&] { load_latent_set(dir + "/nan.t2mckpt"); }, {"non-finite latent"});
}

TEST(VbbEval, ScoresOfKnownReconstructions) {
  bfm::FbAgent a(tiny_fb(), 1);
  const LatentSet s = toy_set(a, "00000000", {6, 21, 9});
  // Identity: zero error; zero latents: mean ||z||^2 = d (every z_t on the sphere of radius sqrt(d)).
  const auto id = evaluate_reconstruction(s, 8, &a, [](const Tensor& z) { return z; }, 2);
  EXPECT_EQ(id.latent_mse, 0.0);
  EXPECT_EQ(id.action_kl, 0.0);
  EXPECT_EQ(id.frames, 5 + 20 + 8);
  EXPECT_EQ(id.windows, 1 + 3 + 1);
  const auto zero = evaluate_reconstruction(s, 8, nullptr, [](const Tensor& z) { return Tensor::zeros(z.shape()); });
  EXPECT_NEAR(zero.latent_mse, 8.0, 1e-4);
  EXPECT_TRUE(std::isnan(zero.action_kl));
  // Eq 21 by hand for one frame of a shifted latent.
  const auto shifted = evaluate_reconstruction(s, 8, &a, [](const Tensor& z) { return add(z, 0.5); }, 3);
  EXPECT_NEAR(shifted.latent_mse, 8 * 0.25, 1e-5);
  EXPECT_GT(shifted.action_kl, 0.0);
  const auto shifted1 = evaluate_reconstruction(s, 8, &a, [](const Tensor& z) { return add(z, 0.5); }, 64);
  EXPECT_NEAR(shifted1.action_kl, shifted.action_kl, 1e-9 * std::abs(shifted.action_kl) + 1e-12);  // batch-free
  // Average pooling with c = 1 is Proj(z) = z; with c = 4 it is worse than with c = 2.
  EXPECT_NEAR(evaluate_average_pooling(s, 1, 8, &a).latent_mse, 0.0, 1e-8);
  const double p2 = evaluate_average_pooling(s, 2, 8, &a).latent_mse, p4 = evaluate_average_pooling(s, 4, 8, &a).latent_mse;
  EXPECT_GT(p2, 0.0);
  EXPECT_GT(p4, p2);
  expect_error([&] { evaluate_average_pooling(s, 3, 8, &a); }, {"vbb eval", "multiple"});
}

TEST(VbbCheckpoint, RoundTripAndBadFiles) {
  const std::string dir = tmp_dir("ckpt");
  VbbConfig c = tiny_train(1).vbb;
  Generator g(3);
  Vbb v(c, g);
  save_vbb(v, dir + "/v.t2mckpt", {{"steps", 7}});
  nlohmann::json info;
  auto r = load_vbb(dir + "/v.t2mckpt", &info);
  EXPECT_EQ(info["steps"], 7);
  EXPECT_FALSE(r->is_training());
  const auto pa = v.named_parameters(), pb = r->named_parameters();
  ASSERT_EQ(pa.size(), pb.size());
  for (size_t i = 0; i < pa.size(); ++i) {
    const Tensor x = pa[i].second.data().contiguous(), y = pb[i].second.data().contiguous();
    EXPECT_EQ(0, std::memcmp(x.data<float>(), y.data<float>(), sizeof(float) * x.numel())) << pa[i].first;
  }
  expect_error([&] { load_vbb(dir + "/none.t2mckpt"); }, {"none.t2mckpt"});
  nn::Checkpoint ck = nn::Checkpoint::load(dir + "/v.t2mckpt");
  ck.meta["config"]["width"] = 32;  // the tensors no longer fit
  ck.save(dir + "/wide.t2mckpt");
  expect_error([&] { load_vbb(dir + "/wide.t2mckpt"); }, {"vbb checkpoint", "wide.t2mckpt"});
  ck = nn::Checkpoint::load(dir + "/v.t2mckpt");
  ck.meta["format"] = "t2m-bfm-policy-1";
  ck.save(dir + "/fmt.t2mckpt");
  expect_error([&] { load_vbb(dir + "/fmt.t2mckpt"); }, {"not a VBB checkpoint"});
  ck = nn::Checkpoint::load(dir + "/v.t2mckpt");
  ck.meta["config"]["levels"] = 7;  // 0..6 are valid (0: no compression)
  ck.save(dir + "/cfg.t2mckpt");
  expect_error([&] { load_vbb(dir + "/cfg.t2mckpt"); }, {"bad config"});
}

TEST(VbbTrain, ResumeIsBitIdentical) {
  const std::string dir = tmp_dir("resume");
  bfm::FbAgent a(tiny_fb(), 1);
  const LatentSet s = toy_set(a, "00000000", {6, 14, 30, 11});
  const VbbTrainConfig cfg = tiny_train(6);
  VbbTrainer straight(cfg, s, &a, toy_text, 12);
  double last = 0;
  for (int i = 0; i < 6; ++i) last = straight.step().total;
  VbbTrainer first(cfg, s, &a, toy_text, 12);
  for (int i = 0; i < 3; ++i) first.step();
  first.save(dir + "/state.t2mckpt");
  VbbTrainer second(cfg, s, &a, toy_text, 12);
  second.load(dir + "/state.t2mckpt");
  EXPECT_EQ(second.steps_done(), 3);
  double last2 = 0;
  for (int i = 0; i < 3; ++i) last2 = second.step().total;
  EXPECT_EQ(last, last2);
  EXPECT_EQ(flat_params(straight, straight.model()), flat_params(second, second.model()));
  ASSERT_NE(straight.head(), nullptr);
  EXPECT_EQ(flat_params(straight, *straight.head()), flat_params(second, *second.head()));
  // Another config refuses the state.
  VbbTrainConfig other = cfg;
  other.lr = 1e-2;
  VbbTrainer wrong(other, s, &a, toy_text, 12);
  expect_error([&] { wrong.load(dir + "/state.t2mckpt"); }, {"state.t2mckpt"});
}

TEST(VbbTrain, TinyOverfitOfTheWholeLoop) {
  bfm::FbAgent a(tiny_fb(), 1);
  const LatentSet s = toy_set(a, "00000000", {17, 17});
  VbbTrainConfig cfg = tiny_train(300);
  cfg.vbb.dropout = 0.0;
  cfg.loss.beta = 1e-4;
  cfg.lr = 1e-2;
  cfg.warmup = 10;
  VbbTrainer t(cfg, s, &a, toy_text, 12);
  const auto before = evaluate_vbb(t.model(), s, 8, &a);
  VbbStepStats st;
  for (int i = 0; i < 300; ++i) st = t.step();
  const auto after = evaluate_vbb(t.model(), s, 8, &a);
  EXPECT_LT(after.latent_mse, 0.1 * before.latent_mse) << before.latent_mse << " -> " << after.latent_mse;
  EXPECT_LT(after.action_kl, 0.1 * before.action_kl) << before.action_kl << " -> " << after.action_kl;
  EXPECT_GT(st.sem, 0.0);
  EXPECT_TRUE(std::isfinite(st.total));
  // Bad input to the trainer.
  VbbTrainConfig bad = cfg;
  bad.window = 7;
  expect_error([&] { VbbTrainer(bad, s, &a, toy_text, 12); }, {"vbb train", "window 7"});
  bad = cfg;
  bad.vbb.in_dim = 9;
  expect_error([&] { VbbTrainer(bad, s, &a, toy_text, 12); }, {"vbb train", "z_dim 8"});
  VbbTrainer broken(cfg, s, &a, [](const std::vector<std::string>&) { return TokenFeatures{Tensor::zeros({1, 2, 12}), Tensor::ones({1, 2})}; }, 12);
  expect_error([&] { broken.step(); }, {"vbb train", "text function"});
}
