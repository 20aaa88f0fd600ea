// test_text_retrieval.cpp — the retrieval checkpoint (round trip of both pairs, bad checkpoints), normalised
// batched embedding with centred crops, and the contrastive trainer (a run stopped and resumed
// equals a straight run bit for bit, its log and plot).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "models/data/captions.h"
#include "models/data/features.h"
#include "models/eval/evaluator.h"
#include "models/text/retrieval_train.h"
#include "models/text/text_motion_model.h"
#include "nn/train_log.h"
#include "tensor/ops.h"
#include "tensor/rng.h"
#include "test_tensor_util.h"
#include "test_scratch_dir.h"

using namespace t2m;
using t2m::testing::expect_error;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir(const std::string& name) {
  return t2m::test::scratch_dir(name);
}

const std::vector<std::pair<std::string, std::string>> kLabels = {
    {"walk", "normal"}, {"run", "happy"}, {"walk", "sad"}, {"run", "angry"}, {"walk", "happy"}, {"run", "normal"}};

text::Tokenizer tokenizer() {
  std::vector<std::string> corpus;
  for (const auto& [c, s] : kLabels)
    for (const auto& t : data::caption_paraphrases(c, s, 0, 8)) corpus.push_back(t);
  return text::Tokenizer::build(corpus);
}

std::vector<data::MotionClip> clips(uint64_t seed) {
  std::vector<data::MotionClip> out;
  Generator g(seed);
  for (size_t i = 0; i < kLabels.size(); ++i) {
    data::MotionClip c;
    c.name = "dataset-2_" + kLabels[i].first + "_" + kLabels[i].second + "_00" + std::to_string(i + 1);
    c.content = kLabels[i].first, c.style = kLabels[i].second;
    c.frames = 10 + 2 * (int)i;
    c.features = rand_normal({c.frames, data::kFeatureDim}, g).to_vector<float>();
    out.push_back(std::move(c));
  }
  return out;
}

data::FeatureStats stats() {
  data::FeatureStats s;
  s.mean.assign(data::kFeatureDim, 0.1f);
  s.std.assign(data::kFeatureDim, 2.0f);
  return s;
}

text::RetrievalBundle text_bundle(uint64_t seed) {
  text::RetrievalBundle b;
  b.tokenizer = tokenizer();
  text::TextMotionConfig c;
  c.text.vocab = b.tokenizer.vocab_size(), c.text.dim = 8, c.text.layers = 1, c.text.heads = 2, c.text.embed_dim = 6;
  c.text.max_len = 24;
  c.motion.dim = 8, c.motion.layers = 1, c.motion.heads = 2, c.motion.patch = 4, c.motion.max_patches = 4;
  c.motion.embed_dim = 6;
  Generator g(seed);
  b.model = std::make_shared<text::TextMotionModel>(c, g);
  b.stats = stats();
  b.window = 12;
  return b;
}

text::RetrievalBundle eval_bundle(uint64_t seed) {
  text::RetrievalBundle b;
  b.tokenizer = tokenizer();
  eval::EvaluatorConfig c;
  c.vocab = b.tokenizer.vocab_size(), c.word_dim = 6, c.text_hidden = 5, c.motion_hidden = 7, c.max_frames = 16;
  c.embed_dim = 6, c.max_len = 24;
  Generator g(seed);
  b.model = std::make_shared<eval::Evaluator>(c, g);
  b.stats = stats();
  b.window = 16;
  return b;
}

std::vector<const std::vector<float>*> feature_ptrs(const std::vector<data::MotionClip>& cs) {
  std::vector<const std::vector<float>*> r;
  for (const auto& c : cs) r.push_back(&c.features);
  return r;
}

std::vector<std::string> captions() {
  std::vector<std::string> r;
  for (const auto& [c, s] : kLabels) r.push_back(data::make_caption(c, s, 3, 0).text);
  return r;
}

}  // namespace

TEST(RetrievalCheckpoint, RoundTripBothKinds) {
  const fs::path d = temp_dir("roundtrip");
  const auto cs = clips(1);
  for (int kind = 0; kind < 2; ++kind) {
    const auto b = kind == 0 ? text_bundle(5) : eval_bundle(6);
    const std::string p = (d / (std::string(b.model->kind()) + ".t2mckpt")).string();
    text::save_retrieval_checkpoint(b, p);
    const auto l = kind == 0 ? text::load_text_motion_model(p) : eval::load_evaluator(p);
    EXPECT_EQ(l.window, b.window);
    EXPECT_EQ(l.tokenizer.vocab(), b.tokenizer.vocab());
    EXPECT_EQ(l.stats.mean, b.stats.mean);
    EXPECT_EQ(max_abs_diff(text::embed_texts(l, captions()), text::embed_texts(b, captions())), 0.0);
    EXPECT_EQ(max_abs_diff(text::embed_motions(l, feature_ptrs(cs)), text::embed_motions(b, feature_ptrs(cs))), 0.0);
  }
}

TEST(RetrievalCheckpoint, BadCheckpoints) {
  const fs::path d = temp_dir("bad");
  const auto b = text_bundle(5);
  const std::string good = (d / "good.t2mckpt").string();
  text::save_retrieval_checkpoint(b, good);
  expect_error([&] { eval::load_evaluator(good); }, {good, "expected 'evaluator'"});
  expect_error([&] { text::load_text_motion_model((d / "missing.t2mckpt").string()); }, {"missing.t2mckpt"});
  {  // truncated
    std::ifstream in(good, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), {});
    std::ofstream((d / "trunc.t2mckpt").string(), std::ios::binary) << bytes.substr(0, bytes.size() / 2);
    expect_error([&] { text::load_text_motion_model((d / "trunc.t2mckpt").string()); }, {"trunc.t2mckpt"});
  }
  auto variant = [&](const std::string& name, const std::function<void(nn::Checkpoint&)>& edit) {
    nn::Checkpoint ck = text::make_retrieval_checkpoint(b);
    edit(ck);
    const std::string p = (d / name).string();
    ck.save(p);
    return p;
  };
  const auto p1 = variant("format.t2mckpt", [](nn::Checkpoint& c) { c.meta["format"] = "something-else"; });
  expect_error([&] { text::load_text_motion_model(p1); }, {"not a retrieval checkpoint"});
  const auto p2 =
      variant("std.t2mckpt", [](nn::Checkpoint& c) { c.put("feature_std", Tensor::zeros({data::kFeatureDim})); });
  expect_error([&] { text::load_text_motion_model(p2); }, {"feature_std"});
  const auto p3 = variant("tok.t2mckpt", [](nn::Checkpoint& c) { c.meta.erase("tokenizer"); });
  expect_error([&] { text::load_text_motion_model(p3); }, {"tokenizer"});
  const auto p4 = variant("window.t2mckpt", [](nn::Checkpoint& c) { c.meta["window"] = 0; });
  expect_error([&] { text::load_text_motion_model(p4); }, {"window"});
  const auto p5 = variant("shape.t2mckpt", [](nn::Checkpoint& c) {
    c.put("model.text.pos_emb", Tensor::zeros({3, 3}));
  });
  expect_error([&] { text::load_text_motion_model(p5); }, {"pos_emb"});
  const auto p6 = variant("vocab.t2mckpt", [](nn::Checkpoint& c) { c.meta["config"]["text"]["vocab"] = 5; });
  expect_error([&] { text::load_text_motion_model(p6); }, {"vocab"});
}

TEST(RetrievalEmbed, UnitRowsCentredCropsAndBatchIndependence) {
  const auto b = text_bundle(7);
  EXPECT_EQ(text::centre_crop(20, 12).start, 4);
  EXPECT_EQ(text::centre_crop(20, 12).len, 12);
  EXPECT_EQ(text::centre_crop(5, 12).start, 0);
  EXPECT_EQ(text::centre_crop(5, 12).len, 5);
  auto cs = clips(2);
  const Tensor m = text::embed_motions(b, feature_ptrs(cs), 64);
  const Tensor m2 = text::embed_motions(b, feature_ptrs(cs), 2);
  EXPECT_LT(max_abs_diff(m, m2), 1e-5);
  for (int64_t i = 0; i < m.size(0); ++i) EXPECT_NEAR(t2m::sum(t2m::square(m.select(0, i))).item(), 1.0, 1e-5);
  // A clip longer than the window is embedded as its centred crop.
  data::MotionClip longer = cs[0];
  Generator g(3);
  longer.frames = 20;
  longer.features = rand_normal({20, data::kFeatureDim}, g).to_vector<float>();
  std::vector<float> crop(longer.features.begin() + 4 * data::kFeatureDim,
                          longer.features.begin() + 16 * data::kFeatureDim);
  EXPECT_LT(max_abs_diff(text::embed_motions(b, {&longer.features}), text::embed_motions(b, {&crop})), 1e-6);
  const Tensor t = text::embed_texts(b, captions());
  EXPECT_EQ(t.shape(), (Shape{(int64_t)kLabels.size(), 6}));
  std::vector<float> empty;
  expect_error([&] { text::embed_motions(b, {&empty}); }, {"embed_motions", "multiple"});
  expect_error([&] { text::embed_texts(b, {}); }, {"embed_texts"});
}

TEST(RetrievalTrain, StopResumeEqualsStraightRun) {
  const auto cs = clips(4);
  text::RetrievalTrainConfig cfg;
  cfg.steps = 8, cfg.batch = 3, cfg.lr = 3e-3, cfg.warmup = 1, cfg.seed = 11, cfg.save_every = 2, cfg.eval_every = 0;
  auto run = [&](const std::string& name, int64_t stop_at, bool resume, text::RetrievalBundle& b) {
    const fs::path d = t2m::test::scratch_root() / name;
    fs::create_directories(d);
    text::RetrievalTrainConfig c = cfg;
    c.stop_at = stop_at;
    text::RetrievalTrainPaths p{(d / "state.t2mckpt").string(), (d / "log.jsonl").string(), (d / "loss.svg").string()};
    return text::train_retrieval(b, cs, {}, c, p, resume, "test");
  };
  temp_dir("straight"), temp_dir("chunked");
  auto a = text_bundle(9);
  run("straight", 0, false, a);
  auto b1 = text_bundle(9);
  EXPECT_EQ(run("chunked", 3, false, b1).steps, 3);
  auto b2 = text_bundle(9);  // a fresh process: same init, state from the file
  EXPECT_EQ(run("chunked", 0, true, b2).steps, 8);
  const auto pa = a.model->named_parameters(), pb = b2.model->named_parameters();
  ASSERT_EQ(pa.size(), pb.size());
  for (size_t i = 0; i < pa.size(); ++i)
    EXPECT_EQ(max_abs_diff(pa[i].second.data(), pb[i].second.data()), 0.0) << pa[i].first;
  const auto log = nn::read_train_log((t2m::test::scratch_root() / "chunked" / "log.jsonl").string());
  ASSERT_EQ(log.size(), 8u);
  EXPECT_EQ(log.back()["step"], 8);
  EXPECT_TRUE(fs::exists(t2m::test::scratch_root() / "chunked" / "loss.svg"));
  // Resuming with another config is refused.
  auto b3 = text_bundle(9);
  cfg.lr = 1e-3;
  expect_error([&] { run("chunked", 0, true, b3); }, {"config"});
}

TEST(RetrievalTrain, BadConfig) {
  const auto cs = clips(4);
  auto b = text_bundle(1);
  text::RetrievalTrainConfig cfg;
  cfg.batch = 64;
  text::RetrievalTrainPaths p{"/nonexistent/s", "/nonexistent/l", ""};
  expect_error([&] { text::train_retrieval(b, cs, {}, cfg, p, false, "x"); },
               {"train_retrieval", "fewer than one batch"});
  cfg.batch = 2;
  b.window = 100;
  expect_error([&] { text::train_retrieval(b, cs, {}, cfg, p, false, "x"); }, {"train_retrieval", "window"});
}

// The shipped checkpoints (models/checkpoints/, docs/TEXT.md) load, have the documented shapes, and rank a
// caption's own paraphrase above captions of other labels.
TEST(ShippedCheckpoints, LoadAndSeparateCaptions) {
  const fs::path dir = fs::path(T2M_SOURCE_DIR) / "models" / "checkpoints";
  if (!fs::exists(dir / "text_encoder.t2mckpt") || !fs::exists(dir / "evaluator.t2mckpt"))
    GTEST_SKIP() << "shipped checkpoints not present";
  const auto te = text::load_text_motion_model((dir / "text_encoder.t2mckpt").string());
  const auto ev = eval::load_evaluator((dir / "evaluator.t2mckpt").string());
  const auto& tm = dynamic_cast<const text::TextMotionModel&>(*te.model);
  EXPECT_EQ(tm.config().text.dim, 256);
  EXPECT_EQ(te.stats.dim(), data::kFeatureDim);
  EXPECT_EQ(ev.window, 128);
  EXPECT_GT(te.tokenizer.vocab_size(), 100);
  const auto enc = te.tokenizer.encode_batch({"a person walks forward"}, tm.config().text.max_len);
  EXPECT_EQ(tm.text().forward(enc.ids, enc.mask).tokens.size(2), 256);
  for (const auto* b : {&te, &ev}) {
    const Tensor e = text::embed_texts(
        *b, {"a person walks forward", "someone walks forward", "a person bows", "an angry person runs forward"});
    const double same = t2m::sum(t2m::mul(e.select(0, 0), e.select(0, 1))).item();
    EXPECT_GT(same, t2m::sum(t2m::mul(e.select(0, 0), e.select(0, 2))).item()) << b->model->kind();
    EXPECT_GT(same, t2m::sum(t2m::mul(e.select(0, 0), e.select(0, 3))).item()) << b->model->kind();
  }
}
