// test_eval_motions.cpp — the motions directory of `t2m eval motions` (.npy round trip and bad files, motions.json
// errors, prompt groups), evaluate_motions on synthetic motions, and the `t2m eval motions` command itself on a
// tiny synthetic directory (report written; bad input: one error line, non-zero exit, no report).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "models/data/captions.h"
#include "models/data/features.h"
#include "models/eval/evaluate_motions.h"
#include "models/eval/evaluator.h"
#include "models/eval/motion_dir.h"
#include "sim/bvh.h"
#include "sim/skeleton.h"
#include "tensor/rng.h"
#include "test_cli_util.h"
#include "test_tensor_util.h"
#include "test_scratch_dir.h"

using namespace t2m;
using t2m::testing::expect_error;
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

constexpr int64_t F = data::kFeatureDim;

fs::path temp_dir(const std::string& name) {
  return t2m::test::scratch_dir(name);
}

void write_text(const fs::path& p, const std::string& s) { std::ofstream(p, std::ios::binary) << s; }

std::vector<float> random_motion(int64_t T, uint64_t seed) {
  Generator g(seed);
  return rand_normal({T, F}, g).to_vector<float>();
}

// A raw .npy: header dict text as given, then `data_bytes` bytes.
std::string npy_bytes(const std::string& dict, const std::string& data, int major = 1) {
  std::string h = dict;
  while ((10 + h.size() + 1) % 16 != 0) h += ' ';
  h += '\n';
  std::string b = "\x93NUMPY";
  b += (char)major;
  b += (char)0;
  if (major == 1) {
    b += (char)(h.size() & 0xff), b += (char)(h.size() >> 8);
  } else {
    uint32_t n = (uint32_t)h.size();
    b.append(reinterpret_cast<const char*>(&n), 4);
  }
  return b + h + data;
}

const std::vector<std::pair<std::string, std::string>> kLabels = {
    {"walk", "normal"}, {"run", "happy"},  {"walk", "sad"},   {"run", "angry"},
    {"walk", "happy"},  {"run", "normal"}, {"walk", "angry"}, {"run", "sad"}};

// 40 motions with captions (no prompts) + 2 prompts x 3 samples.
fs::path synthetic_dir(const std::string& name) {
  const fs::path d = temp_dir(name);
  json ms = json::array();
  for (int i = 0; i < 40; ++i) {
    const auto& [c, s] = kLabels[i % kLabels.size()];
    std::string f = "m";
    f.append(std::to_string(i)).append(".npy");
    eval::write_npy_features((d / f).string(), random_motion(6 + i % 5, 100 + i));
    ms.push_back({{"file", f}, {"caption", data::make_caption(c, s, 1, i).text}});
  }
  for (int p = 0; p < 2; ++p)
    for (int k = 0; k < 3; ++k) {
      std::string f = "p";
      f.append(std::to_string(p)).append("_").append(std::to_string(k)).append(".npy");
      eval::write_npy_features((d / f).string(), random_motion(8, 500 + 10 * p + k));
      ms.push_back({{"file", f}, {"caption", "a person walks forward"}, {"prompt", p}});
    }
  write_text(d / "motions.json", json{{"format", "t2m-motions-1"}, {"motions", ms}}.dump());
  return d;
}

text::RetrievalBundle tiny_evaluator() {
  std::vector<std::string> corpus;
  for (const auto& [c, s] : kLabels)
    for (const auto& t : data::caption_paraphrases(c, s, 1, 8)) corpus.push_back(t);
  text::RetrievalBundle b;
  b.tokenizer = text::Tokenizer::build(corpus);
  eval::EvaluatorConfig c;
  c.vocab = b.tokenizer.vocab_size(), c.word_dim = 6, c.text_hidden = 6, c.motion_hidden = 6, c.max_frames = 16;
  c.embed_dim = 8;
  Generator g(3);
  b.model = std::make_shared<eval::Evaluator>(c, g);
  b.stats.mean.assign(F, 0.0f);
  b.stats.std.assign(F, 1.0f);
  b.window = 16;
  return b;
}

}  // namespace

TEST(MotionNpy, RoundTripAndFloat64) {
  const fs::path d = temp_dir("npy");
  const auto m = random_motion(7, 1);
  eval::write_npy_features((d / "a.npy").string(), m);
  EXPECT_EQ(eval::read_npy_features((d / "a.npy").string()), m);
  std::vector<double> v(2 * F);
  for (size_t i = 0; i < v.size(); ++i) v[i] = 0.5 * (double)i;
  write_text(d / "b.npy", npy_bytes("{'descr': '<f8', 'fortran_order': False, 'shape': (2, 257), }",
                                    std::string(reinterpret_cast<const char*>(v.data()), v.size() * 8), 2));
  const auto r = eval::read_npy_features((d / "b.npy").string());
  ASSERT_EQ(r.size(), v.size());
  EXPECT_EQ(r[300], 150.0f);
}

TEST(MotionNpy, BadFiles) {
  const fs::path d = temp_dir("npybad");
  const std::string four(4 * F, '\0');
  auto check = [&](const std::string& name, const std::string& bytes, const std::string& part) {
    write_text(d / name, bytes);
    expect_error([&] { eval::read_npy_features((d / name).string()); }, {name, part});
  };
  check("magic.npy", "NOTNUMPY" + four, "not a .npy file");
  check("version.npy", npy_bytes("{'descr': '<f4', 'fortran_order': False, 'shape': (1, 257), }", four, 9), "version");
  check("dtype.npy", npy_bytes("{'descr': '<i4', 'fortran_order': False, 'shape': (1, 257), }", four), "dtype");
  check("fortran.npy", npy_bytes("{'descr': '<f4', 'fortran_order': True, 'shape': (1, 257), }", four), "Fortran");
  check("shape.npy", npy_bytes("{'descr': '<f4', 'fortran_order': False, 'shape': (1, 256), }", four), "shape");
  check("rank.npy", npy_bytes("{'descr': '<f4', 'fortran_order': False, 'shape': (257,), }", four), "shape");
  check("trunc.npy", npy_bytes("{'descr': '<f4', 'fortran_order': False, 'shape': (2, 257), }", four), "truncated");
  std::string nan = four;
  const float q = NAN;
  std::memcpy(nan.data() + 8, &q, 4);
  check("nan.npy", npy_bytes("{'descr': '<f4', 'fortran_order': False, 'shape': (1, 257), }", nan), "non-finite");
  expect_error([&] { eval::read_npy_features((d / "none.npy").string()); }, {"none.npy", "cannot open"});
}

TEST(MotionDir, BadDirectories) {
  const fs::path d = temp_dir("dirbad");
  eval::write_npy_features((d / "ok.npy").string(), random_motion(3, 2));
  auto with = [&](const std::string& body) { write_text(d / "motions.json", body); };
  auto expect = [&](const std::string& part) { expect_error([&] { eval::load_motion_dir(d.string()); }, {part}); };
  expect_error([&] { eval::load_motion_dir((d / "nope").string()); }, {"not a directory"});
  expect("no motions.json");
  with("{not json");
  expect("bad JSON");
  with(R"({"format": "other", "motions": []})");
  expect("t2m-motions-1");
  with(R"({"format": "t2m-motions-1", "motions": []})");
  expect("non-empty list");
  with(R"({"format": "t2m-motions-1", "motions": [{"file": "ok.npy"}]})");
  expect("caption");
  with(R"({"format": "t2m-motions-1", "motions": [{"file": "../ok.npy", "caption": "a"}]})");
  expect("relative path inside");
  with(R"({"format": "t2m-motions-1", "motions": [{"file": "gone.npy", "caption": "a"}]})");
  expect("does not exist");
  write_text(d / "x.txt", "hello");
  with(R"({"format": "t2m-motions-1", "motions": [{"file": "x.txt", "caption": "a"}]})");
  expect("neither .npy nor .bvh");
  with(R"({"format": "t2m-motions-1", "motions": [{"file": "ok.npy", "caption": "a", "prompt": -1}]})");
  expect("prompt");
  with(R"({"format": "t2m-motions-1", "motions": [{"file": "ok.npy", "caption": "a", "prompt": 0},
          {"file": "ok.npy", "caption": "a", "prompt": 0}, {"file": "ok.npy", "caption": "b", "prompt": 1}]})");
  expect("same number");
  write_text(d / "bad.bvh", "HIERARCHY\nnonsense");
  with(R"({"format": "t2m-motions-1", "motions": [{"file": "bad.bvh", "caption": "a"}]})");
  expect_error([&] { eval::load_motion_dir(d.string()); }, {"bad.bvh"});
}

TEST(MotionDir, MainSetAndPromptGroups) {
  const fs::path d = synthetic_dir("groups");
  const auto md = eval::load_motion_dir(d.string());
  ASSERT_EQ(md.entries.size(), 46u);
  EXPECT_EQ(md.entries[3].frames, 9);
  const auto main = md.main_set();
  ASSERT_EQ(main.size(), 42u);  // 40 + the first sample of each prompt
  EXPECT_EQ(main[40], 40);
  EXPECT_EQ(main[41], 43);
  const auto g = md.prompt_groups();
  ASSERT_EQ(g.size(), 2u);
  EXPECT_EQ(g[1], (std::vector<int64_t>{43, 44, 45}));
}

TEST(EvaluateMotions, SelfReferenceFidIsZeroAndMetricsInRange) {
  const fs::path d = synthetic_dir("evaluate");
  const auto md = eval::load_motion_dir(d.string());
  const auto ev = tiny_evaluator();
  eval::MotionSet set;
  for (int64_t i : md.main_set())
    set.captions.push_back(md.entries[i].caption), set.motions.push_back(&md.entries[i].features);
  for (const auto& g : md.prompt_groups()) {
    set.groups.emplace_back();
    for (int64_t i : g) set.groups.back().push_back(&md.entries[i].features);
  }
  eval::EvalProtocol p;
  p.runs = 3;
  const Tensor ref = text::embed_motions(ev, set.motions);
  const auto r = eval::evaluate_motions(ev, set, ref, p);
  EXPECT_LT(std::abs(r.at("fid").mean), 1e-6);
  EXPECT_EQ(r.protocol.diversity_pairs, 42);  // clamped to the number of motions
  EXPECT_EQ(r.protocol.mm_pairs, 3);          // clamped to the samples per prompt
  for (int k = 1; k <= 3; ++k) {
    const double v = r.at("r_precision_top" + std::to_string(k)).mean;
    EXPECT_GE(v, 0.0);
    EXPECT_LE(v, 1.0);
  }
  EXPECT_GT(r.at("diversity").mean, 0.0);
  EXPECT_GT(r.at("multimodality").mean, 0.0);
  EXPECT_GT(r.at("mm_dist").mean, 0.0);
  EXPECT_FALSE(eval::evaluate_motions(ev, set, Tensor(), p).has("fid"));
  eval::MotionSet few;
  few.captions = {"a"}, few.motions = {set.motions[0]};
  expect_error([&] { eval::evaluate_motions(ev, few, Tensor(), p); }, {"evaluate_motions", "at least one batch of 32"});
}

using t2m::test::read_text;
using t2m::test::run_t2m;
using t2m::test::t2m_binary;

TEST(EvalMotionsCommand, SyntheticDirectoryAndBadInput) {
  if (!fs::exists(t2m_binary())) GTEST_SKIP() << "t2m binary not built next to the test";
  const fs::path d = synthetic_dir("cmd"), w = temp_dir("cmdwork");
  const std::string ck = (w / "ev.t2mckpt").string();
  text::save_retrieval_checkpoint(tiny_evaluator(), ck);
  const fs::path out = w / "report.json";
  ASSERT_EQ(run_t2m("eval motions '" + d.string() + "' --evaluator '" + ck + "' --reference '" + d.string() +
                        "' --runs 2 --out '" + out.string() + "'",
                    w / "ok.log"),
            0)
      << read_text(w / "ok.log");
  const json j = json::parse(read_text(out));
  EXPECT_EQ(j["runs"], 2);
  EXPECT_EQ(j["count"], 42);
  EXPECT_EQ(j["multimodality_prompts"], 2);
  for (const char* k : {"r_precision_top1", "control_r_precision_top3", "fid", "mm_dist", "diversity", "multimodality"})
    EXPECT_TRUE(j["metrics"].contains(k)) << k;

  // Bad input: one "t2m: ..." line, exit status 1, no report.
  const fs::path none = w / "none.json";
  EXPECT_EQ(run_t2m("eval motions '" + (w / "missing").string() + "' --evaluator '" + ck +
                        "' --reference none --out '" + none.string() + "'",
                    w / "bad1.log"),
            1);
  const std::string bad1 = read_text(w / "bad1.log");
  EXPECT_EQ(bad1.rfind("t2m: motions ", 0), 0u) << bad1;
  EXPECT_EQ(std::count(bad1.begin(), bad1.end(), '\n'), 1) << bad1;
  EXPECT_EQ(run_t2m("eval motions '" + d.string() + "' --evaluator '" + (w / "nope.t2mckpt").string() +
                        "' --reference none --out '" + none.string() + "'",
                    w / "bad2.log"),
            1);
  EXPECT_NE(read_text(w / "bad2.log").find("not found"), std::string::npos) << read_text(w / "bad2.log");
  EXPECT_EQ(run_t2m("eval motions '" + d.string() + "' --real --evaluator '" + ck + "' --out '" + none.string() +
                        "'",
                    w / "bad3.log"),
            1);
  EXPECT_NE(read_text(w / "bad3.log").find("not both"), std::string::npos) << read_text(w / "bad3.log");
  EXPECT_FALSE(fs::exists(none));
}

TEST(MotionDir, BvhEntryGivesTheClipFeatures) {
  const fs::path d = temp_dir("bvh");
  const std::string src = std::string(T2M_SOURCE_DIR) + "/tests/fixtures/bvh/bandai_walk_60.bvh";
  fs::copy_file(src, d / "walk.bvh");
  write_text(d / "motions.json",
             R"({"format": "t2m-motions-1", "motions": [{"file": "walk.bvh", "caption": "a person walks"}]})");
  const auto md = eval::load_motion_dir(d.string());
  ASSERT_EQ(md.entries.size(), 1u);
  const auto want = data::motion_to_features(sim::motion_from_bvh(sim::read_bvh(src)));
  EXPECT_EQ(md.entries[0].frames, (int64_t)(want.size() / F));
  EXPECT_EQ(md.entries[0].features, want);
}

TEST(EvalMotionsReport, MotionSetOfADirectoryAndTheMarkdownRow) {
  t2m::eval::MotionDir md;
  auto entry = [](const char* cap, int64_t prompt) {
    t2m::eval::MotionEntry e;
    e.caption = cap, e.prompt = prompt, e.frames = 1;
    e.features.assign(257, float(prompt + 2));
    return e;
  };
  md.entries = {entry("a", -1), entry("b", 0), entry("b", 0), entry("c", 1), entry("c", 1)};
  const auto set = t2m::eval::motion_set_of(md);
  ASSERT_EQ(set.captions, (std::vector<std::string>{"a", "b", "c"}));  // un-prompted + first of each prompt
  ASSERT_EQ(set.motions.size(), 3u);
  EXPECT_EQ(set.motions[1], &md.entries[1].features);
  ASSERT_EQ(set.groups.size(), 2u);
  EXPECT_EQ(set.groups[1][1], &md.entries[4].features);

  t2m::eval::EvalReport rep;
  rep.names = {"r_precision_top1", "fid"};
  rep.values.resize(2);
  rep.values[0].mean = 0.5, rep.values[0].ci95 = 0.01;
  rep.values[1].mean = 1.25, rep.values[1].ci95 = 0.0;
  EXPECT_EQ(t2m::eval::report_markdown_row("x", rep), "| x | 0.500 ± 0.010 | – | – | 1.250 ± 0.000 | – | – | – |");
  EXPECT_EQ(t2m::eval::report_lines(rep),
            "  r_precision_top1             0.5000 +- 0.0100\n  fid                          1.2500 +- 0.0000\n");
}
