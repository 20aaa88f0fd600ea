// test_text2bfm_pipeline.cpp — `t2m generate`'s pipeline end to end with tiny randomly initialised models saved to
// a temp dir (no shipped checkpoint needed): outputs written atomically, determinism, bad input refused.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "models/bfm/policy_checkpoint.h"
#include "models/data/features.h"
#include "models/text/text_motion_model.h"
#include "models/text2bfm/pipeline.h"
#include "models/text2bfm/vbb_checkpoint.h"
#include "nn/checkpoint.h"
#include "sim/bvh.h"
#include "tiny_text2bfm.h"

using namespace t2m;
namespace fs = std::filesystem;
using text2bfm::GenerateOptions;
using text2bfm::PipelinePaths;

namespace {

constexpr int64_t kZ = test_util::kTinyZ;  // tiny BFM latent width

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("t2m_pipeline_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

// The four tiny checkpoints in one directory.
class Pipeline : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(fresh_dir("ckpt"));
    const auto p = test_util::save_tiny_text2bfm(dir_->string());
    models_ = new text2bfm::Text2BfmModels(text2bfm::load_text2bfm(p));
  }
  static void TearDownTestSuite() {
    delete models_;
    fs::remove_all(*dir_);
    delete dir_;
  }
  static GenerateOptions short_clip(uint64_t seed = 0) {
    GenerateOptions o;
    o.seed = seed;
    o.length_s = 1.0;
    o.steps = 4;
    return o;
  }
  static inline fs::path* dir_ = nullptr;
  static inline text2bfm::Text2BfmModels* models_ = nullptr;
};

text2bfm::WriteOptions no_render() {
  text2bfm::WriteOptions w;
  w.render = false;
  return w;
}

// Entries of a directory (names), to check that nothing was left behind.
std::vector<std::string> entries(const fs::path& d) {
  std::vector<std::string> r;
  for (const auto& e : fs::directory_iterator(d)) r.push_back(e.path().filename().string());
  std::sort(r.begin(), r.end());
  return r;
}

}  // namespace

TEST_F(Pipeline, EndToEndWritesEveryOutput) {
  const fs::path root = fresh_dir("e2e");
  const fs::path out = root / "walk";
  auto g = text2bfm::generate_motion(*models_, "A person walks forward", short_clip(7));
  const auto metrics = text2bfm::write_generation(g, *models_, out.string(), no_render());
  EXPECT_EQ(entries(root), std::vector<std::string>{"walk"});  // no temp dir left
  EXPECT_EQ(entries(out), (std::vector<std::string>{"metrics.json", "motion.bvh", "states.bin"}));
  // 1 s = 30 control steps from the standing start: 31 states.
  EXPECT_EQ(g.traj.frames, 31);
  ASSERT_EQ(g.z.shape(), (Shape{30, kZ}));
  for (int64_t t = 0; t < 30; ++t) {  // latents on the policy's sphere
    double n2 = 0;
    for (int64_t k = 0; k < kZ; ++k) n2 += g.z.at({t, k}) * g.z.at({t, k});
    EXPECT_NEAR(std::sqrt(n2), std::sqrt(double(kZ)), 1e-4);
  }
  std::ifstream mf(out / "metrics.json");
  const auto mj = nlohmann::json::parse(mf);
  EXPECT_EQ(mj, metrics);
  EXPECT_DOUBLE_EQ(mj["duration_s"].get<double>(), 1.0);
  EXPECT_EQ(mj["frames"].get<int>(), 31);
  EXPECT_EQ(mj["falls"].get<int>(), g.falls);
  for (const char* k : {"text", "sample", "decode", "rollout", "export", "total"})
    EXPECT_GE(mj["timing_s"][k].get<double>(), 0.0) << k;
  const nn::Checkpoint st = nn::Checkpoint::load((out / "states.bin").string());
  EXPECT_EQ(st.meta["format"], "t2m-states-1");
  EXPECT_EQ(st.get("obs").shape(), (Shape{31, 313}));
  EXPECT_EQ(st.get("qpos").shape(), (Shape{31, 67}));
  EXPECT_EQ(st.get("z").shape(), (Shape{30, kZ}));
  // The start is the standing pose (root at qpos0, soles on the floor).
  EXPECT_NEAR(st.get("qpos").at({0, 2}), models_->humanoid->model()->qpos0[2], 1e-9);
  // The BVH parses back with the data's frame count.
  const sim::BvhMotion bvh = sim::read_bvh((out / "motion.bvh").string());
  EXPECT_EQ(bvh.frames, 31);
  fs::remove_all(root);
}

TEST_F(Pipeline, DeterministicForASeed) {
  const auto a = text2bfm::generate_motion(*models_, "someone waves with the right hand", short_clip(3));
  const auto b = text2bfm::generate_motion(*models_, "someone waves with the right hand", short_clip(3));
  const auto c = text2bfm::generate_motion(*models_, "someone waves with the right hand", short_clip(4));
  EXPECT_EQ(a.z.to_vector<float>(), b.z.to_vector<float>());
  EXPECT_EQ(a.traj.qpos, b.traj.qpos);
  EXPECT_NE(a.z.to_vector<float>(), c.z.to_vector<float>());
}

// --candidates K: the chain runs with seeds seed .. seed + K - 1 and keeps the rollout upright longest (no fall
// beats any fall, then fewer falls, then the lower seed); the kept one is bit for bit that seed's single run, the
// upright times are each candidate's own, and K = 1 is the plain chain.
TEST_F(Pipeline, CandidatesKeepTheLongestUprightRollout) {
  auto o = short_clip(11);
  o.length_s = 4.0;
  const std::string prompt = "a person jumps";
  std::vector<text2bfm::Generation> single;
  for (uint64_t k = 0; k < 4; ++k) {
    auto ok = o;
    ok.seed = o.seed + k;
    single.push_back(text2bfm::generate_motion(*models_, prompt, ok));
    ASSERT_EQ(single.back().candidate_upright_s.size(), 1u);
    std::printf("seed %llu: falls %d, first fall %.3f s\n", (unsigned long long)ok.seed, single.back().falls,
                single.back().first_fall_s);
  }
  auto key = [](const text2bfm::Generation& g) {  // larger is better
    return std::make_pair(g.first_fall_s < 0 ? 1e9 : g.first_fall_s, -g.falls);
  };
  size_t want = 0;
  for (size_t k = 1; k < single.size(); ++k)
    if (key(single[k]) > key(single[want])) want = k;
  EXPECT_NE(key(single[0]), key(single[want]));  // the case is not trivial: seed 11 is not the best
  auto ok = o;
  ok.candidates = 4;
  auto best = text2bfm::generate_motion(*models_, prompt, ok);
  EXPECT_EQ(best.candidate, (int64_t)want);
  EXPECT_EQ(best.z.to_vector<float>(), single[want].z.to_vector<float>());
  EXPECT_EQ(best.traj.qpos, single[want].traj.qpos);
  ASSERT_EQ(best.candidate_upright_s.size(), 4u);
  for (size_t k = 0; k < 4; ++k) EXPECT_EQ(best.candidate_upright_s[k], single[k].candidate_upright_s[0]) << k;
  EXPECT_EQ(best.opt.seed, o.seed);  // the base seed; the kept one's is seed + candidate
  const fs::path root = fresh_dir("cand");
  const auto mj = text2bfm::write_generation(best, *models_, (root / "o").string(), no_render());
  EXPECT_EQ(mj["candidate"].get<int64_t>(), (int64_t)want);
  EXPECT_EQ(mj["candidate_seed"].get<uint64_t>(), o.seed + want);
  EXPECT_EQ(mj["options"]["candidates"].get<int64_t>(), 4);
  fs::remove_all(root);
  for (int64_t bad : {0, -1, 65}) {
    auto ob = o;
    ob.candidates = bad;
    EXPECT_THROW(text2bfm::generate_motion(*models_, prompt, ob), Error) << bad;
  }
}

// A given start state (evaluation only) replaces the standing start: frame 0 is that state; the default is qpos0 at
// rest; a state of the wrong size, or only one of qpos / qvel, is refused before any work.
TEST_F(Pipeline, StartStateReplacesTheStandingStart) {
  const mjModel* mm = models_->humanoid->model();
  auto o = short_clip(2);
  std::vector<double> q(mm->qpos0, mm->qpos0 + mm->nq), v((size_t)mm->nv, 0.0);
  q[2] += 0.05;  // the root 5 cm higher
  v[0] = 0.3;    // moving along x
  o.start_qpos = q, o.start_qvel = v;
  const auto g = text2bfm::generate_motion(*models_, "a person waves", o);
  for (int k = 0; k < mm->nq; ++k) EXPECT_EQ(g.traj.qpos[k], q[k]) << k;
  for (int k = 0; k < mm->nv; ++k) EXPECT_EQ(g.traj.qvel[k], v[k]) << k;
  const auto stand = text2bfm::generate_motion(*models_, "a person waves", short_clip(2));
  EXPECT_EQ(stand.traj.qpos[2], mm->qpos0[2]);
  EXPECT_EQ(stand.z.to_vector<float>(), g.z.to_vector<float>());  // same programs, other rollout
  EXPECT_NE(stand.traj.qpos, g.traj.qpos);
  auto bad = o;
  bad.start_qvel.clear();
  EXPECT_THROW(text2bfm::generate_motion(*models_, "a person waves", bad), Error);
  bad = o;
  bad.start_qpos.pop_back();
  EXPECT_THROW(text2bfm::generate_motion(*models_, "a person waves", bad), Error);
}

TEST_F(Pipeline, ComposeOneProgramPerClause) {
  auto o = short_clip(1);
  o.compose = true;
  o.overlap = 2;
  o.length_s = 2.0;
  const auto g = text2bfm::generate_motion(*models_, "a person walks forward, then someone sits down", o);
  EXPECT_EQ(g.clauses, (std::vector<std::string>{"a person walks forward", "someone sits down"}));
  EXPECT_EQ(g.z.size(0), 60);
  EXPECT_EQ(g.traj.frames, 61);
}

TEST_F(Pipeline, RefusesBadInputAndWritesNothing) {
  const fs::path root = fresh_dir("bad");
  const std::string out = (root / "o").string();
  auto attempt = [&](const std::string& prompt, GenerateOptions o) {
    auto g = text2bfm::generate_motion(*models_, prompt, o);
    text2bfm::write_generation(g, *models_, out, no_render());
  };
  EXPECT_THROW(attempt("", short_clip()), Error);
  EXPECT_THROW(attempt("  , . ", short_clip()), Error);
  EXPECT_THROW(attempt("xyzzy plugh", short_clip()), Error);  // only unknown words
  auto bad = short_clip();
  bad.length_s = 0;
  EXPECT_THROW(attempt("a person walks", bad), Error);
  bad = short_clip(), bad.steps = 0;
  EXPECT_THROW(attempt("a person walks", bad), Error);
  bad = short_clip(), bad.cfg = NAN;
  EXPECT_THROW(attempt("a person walks", bad), Error);
  bad = short_clip(), bad.compose = true;
  EXPECT_THROW(attempt("a person walks, then xyzzy", bad), Error);  // a clause with no known word
  EXPECT_TRUE(entries(root).empty());
  // Unwritable: the parent does not exist.
  auto g = text2bfm::generate_motion(*models_, "a person runs", short_clip());
  EXPECT_THROW(text2bfm::write_generation(g, *models_, (root / "no" / "such" / "dir").string(), no_render()),
               Error);
  // An existing non-empty directory is refused and left unchanged; --overwrite replaces it whole.
  fs::create_directories(out);
  std::ofstream(fs::path(out) / "keep.txt") << "x";
  EXPECT_THROW(text2bfm::write_generation(g, *models_, out, no_render()), Error);
  EXPECT_EQ(entries(out), std::vector<std::string>{"keep.txt"});
  auto w = no_render();
  w.overwrite = true;
  text2bfm::write_generation(g, *models_, out, w);
  EXPECT_EQ(entries(out), (std::vector<std::string>{"metrics.json", "motion.bvh", "states.bin"}));
  EXPECT_EQ(entries(root), std::vector<std::string>{"o"});
  fs::remove_all(root);
}

TEST_F(Pipeline, MissingOrMismatchedCheckpoints) {
  const fs::path d = fresh_dir("missing");
  const auto good = PipelinePaths::in_dir(dir_->string());
  auto p = good;
  p.gen = (d / "gen_small.t2mckpt").string();
  try {
    text2bfm::load_text2bfm(p);
    ADD_FAILURE() << "no error for a missing generator";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("t2m train gen"), std::string::npos) << e.what();
  }
  // A VBB of another latent width does not fit the generator.
  text2bfm::VbbConfig vc;
  vc.in_dim = kZ, vc.width = 16, vc.latent = 6, vc.levels = 2, vc.depth = 1, vc.groups = 4;
  Generator g(0);
  text2bfm::save_vbb(text2bfm::Vbb(vc, g), (d / "vbb.t2mckpt").string());
  p = good;
  p.vbb = (d / "vbb.t2mckpt").string();
  EXPECT_THROW(text2bfm::load_text2bfm(p), Error);
  // A generator trained on another BFM's latents loads, with a warning.
  {
    auto gb = text2bfm::load_gen_checkpoint(good.gen);
    gb.train = {{"bfm_checksum", "deadbeef"}};
    text2bfm::save_gen_checkpoint(gb, (d / "gen_other.t2mckpt").string());
    p = good;
    p.gen = (d / "gen_other.t2mckpt").string();
    const auto m = text2bfm::load_text2bfm(p);
    ASSERT_EQ(m.warnings.size(), 1u);
    EXPECT_NE(m.warnings[0].find("deadbeef"), std::string::npos);
    EXPECT_TRUE(models_->warnings.empty());
    // A generator that records the latent space (B's checksum) loads without a warning beside a policy with
    // that B whatever the file's checksum (a fine-tuned actor), and with one beside another B.
    gb.train["bfm_latent_checksum"] = bfm::latent_space_checksum(*models_->policy);
    text2bfm::save_gen_checkpoint(gb, (d / "gen_same_b.t2mckpt").string());
    p.gen = (d / "gen_same_b.t2mckpt").string();
    EXPECT_TRUE(text2bfm::load_text2bfm(p).warnings.empty());
    gb.train["bfm_latent_checksum"] = "0123456789abcdef";
    text2bfm::save_gen_checkpoint(gb, (d / "gen_other_b.t2mckpt").string());
    p.gen = (d / "gen_other_b.t2mckpt").string();
    const auto m2 = text2bfm::load_text2bfm(p);
    ASSERT_EQ(m2.warnings.size(), 1u);
    EXPECT_NE(m2.warnings[0].find("0123456789abcdef"), std::string::npos);
  }
  // A corrupted generator file.
  std::ofstream(d / "bad.t2mckpt") << "not a checkpoint";
  p = good;
  p.gen = (d / "bad.t2mckpt").string();
  EXPECT_THROW(text2bfm::load_text2bfm(p), Error);
  fs::remove_all(d);
}
