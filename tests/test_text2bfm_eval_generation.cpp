// test_text2bfm_eval_generation.cpp — `t2m eval text2bfm`'s generation step (models/text2bfm/eval_generation.h)
// and the motions-directory writer (models/eval/motion_dir_write.h) with tiny random models: lengths, file layout,
// MultiModality groups, independence of the job count, round trip through load_motion_dir, errors; the Table 2
// runner (compose_eval.h) on the same tiny chain.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>

#include "models/eval/motion_dir.h"
#include "models/eval/motion_dir_write.h"
#include "models/text2bfm/compose_eval.h"
#include "models/text2bfm/eval_generation.h"
#include "sim/retarget.h"
#include "tests/tiny_text2bfm.h"

using namespace t2m;
namespace fs = std::filesystem;

namespace {

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("t2m_evalgen_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

class EvalGeneration : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(fresh_dir("ckpt"));
    models_ = new text2bfm::Text2BfmModels(text2bfm::load_text2bfm(test_util::save_tiny_text2bfm(dir_->string())));
  }
  static void TearDownTestSuite() {
    delete models_;
    fs::remove_all(*dir_);
    delete dir_;
  }
  static std::vector<text2bfm::EvalItem> items() {
    return {{"a person walks forward", 12}, {"someone waves with the right hand", 9},
            {"a person runs in a circle", 15}, {"someone sits down", 7}};
  }
  static text2bfm::EvalGenOptions options(int jobs) {
    text2bfm::EvalGenOptions o;
    o.gen.steps = 3;
    o.seed = 5;
    o.mm_prompts = 2;
    o.samples = 3;
    o.jobs = jobs;
    return o;
  }
  static inline fs::path* dir_ = nullptr;
  static inline text2bfm::Text2BfmModels* models_ = nullptr;
};

}  // namespace

TEST_F(EvalGeneration, TrajectoryFeaturesDropTheStartState) {
  auto g = text2bfm::generate_motion(*models_, "a person walks forward", {.seed = 1, .length_s = 0.3, .steps = 2});
  ASSERT_EQ(g.traj.frames, 10);  // 9 control steps + the standing start
  const auto f1 = text2bfm::trajectory_features(*models_->humanoid, g.traj, 1);
  const auto f0 = text2bfm::trajectory_features(*models_->humanoid, g.traj, 0);
  EXPECT_EQ(f1.size(), 9u * data::kFeatureDim);
  EXPECT_EQ(f0.size(), 10u * data::kFeatureDim);
  // Root height (feature 3) of frame t in f1 is frame t + 1 of the trajectory.
  const int root = models_->humanoid->root_qpos();
  for (int t = 0; t < 9; ++t)
    EXPECT_NEAR(f1[(size_t)t * data::kFeatureDim + data::kFeatRootHeight], g.traj.qpos[(size_t)(t + 1) * g.traj.nq + root + 2],
                1e-4);
  EXPECT_THROW(text2bfm::trajectory_features(*models_->humanoid, g.traj, 10), Error);
}

TEST_F(EvalGeneration, LayoutGroupsAndJobIndependence) {
  const auto r1 = text2bfm::generate_eval_motions(*models_, items(), options(1));
  const auto r2 = text2bfm::generate_eval_motions(*models_, items(), options(2));
  // mm prompts at items floor(k * 4 / 2) = 0, 2 with 3 samples; items 1, 3 once: 3 + 1 + 3 + 1 entries.
  const std::vector<std::string> files{"0000_00.npy", "0000_01.npy", "0000_02.npy", "0001.npy",
                                       "0002_00.npy", "0002_01.npy", "0002_02.npy", "0003.npy"};
  const std::vector<int64_t> prompts{0, 0, 0, -1, 1, 1, 1, -1};
  const std::vector<int64_t> frames{12, 12, 12, 9, 15, 15, 15, 7};
  ASSERT_EQ(r1.entries.size(), files.size());
  for (size_t i = 0; i < files.size(); ++i) {
    EXPECT_EQ(r1.entries[i].file, files[i]);
    EXPECT_EQ(r1.entries[i].prompt, prompts[i]);
    EXPECT_EQ(r1.entries[i].frames, frames[i]);
    EXPECT_EQ(r1.entries[i].features.size(), (size_t)frames[i] * data::kFeatureDim);
    EXPECT_EQ(r1.entries[i].features, r2.entries[i].features) << files[i];  // same bits for any job count
  }
  EXPECT_EQ(r1.entries[4].caption, "a person runs in a circle");
  EXPECT_NE(r1.entries[0].features, r1.entries[1].features);  // samples of a prompt differ (their own seeds)
  EXPECT_EQ(r1.stats.generations, 8);
  EXPECT_EQ(r1.stats.control_steps, 12 * 3 + 9 + 15 * 3 + 7);
  EXPECT_GE(r1.stats.fell, 0);
  // Written and read back: main set = every item once, groups = the two prompts.
  const fs::path d = fresh_dir("dir") / "motions";
  eval::write_motion_dir(d.string(), r1.entries, {{"provenance", "test"}});
  const auto md = eval::load_motion_dir(d.string());
  EXPECT_EQ(md.main_set(), (std::vector<int64_t>{0, 3, 4, 7}));
  ASSERT_EQ(md.prompt_groups().size(), 2u);
  EXPECT_EQ(md.prompt_groups()[1], (std::vector<int64_t>{4, 5, 6}));
  EXPECT_EQ(md.entries[7].features, r1.entries[7].features);
  // Rewriting replaces the directory, leaving no temporary sibling.
  eval::write_motion_dir(d.string(), {r1.entries[3]});
  EXPECT_EQ(eval::load_motion_dir(d.string()).entries.size(), 1u);
  int siblings = 0;
  for (const auto& e : fs::directory_iterator(d.parent_path())) siblings += e.is_directory();
  EXPECT_EQ(siblings, 1);
  fs::remove_all(d.parent_path());
}

// item_fell[i] says whether item i's main generation (sample 0, seed sample_seed(seed, i, 0)) fell: the same
// as generating that item alone; long items (4 s) fall with these untrained models, the short one does not.
TEST_F(EvalGeneration, ItemFellIsTheMainGenerationsFall) {
  const std::vector<text2bfm::EvalItem> its{{"a person jumps", 120}, {"someone waves with the right hand", 6},
                                            {"a person runs in a circle", 120}};
  auto o = options(2);
  o.mm_prompts = 1;  // item 0 gets 3 samples; only sample 0 counts
  const auto r = text2bfm::generate_eval_motions(*models_, its, o);
  ASSERT_EQ(r.item_fell.size(), its.size());
  int64_t fell = 0;
  for (size_t i = 0; i < its.size(); ++i) {
    auto go = o.gen;
    go.seed = text2bfm::sample_seed(o.seed, (int64_t)i, 0);
    go.length_s = double(its[i].frames) * sim::kControlDt;
    const bool f = text2bfm::generate_motion(*models_, its[i].caption, go).falls > 0;
    EXPECT_EQ(r.item_fell[i], f) << i;
    fell += f;
  }
  EXPECT_GE(fell, 1);                       // the check is not vacuous
  EXPECT_FALSE(r.item_fell[1]);             // 0.2 s: nothing to fall from
  EXPECT_LE(fell, r.stats.fell);            // stats.fell also counts the extra samples
}

TEST_F(EvalGeneration, BadInputsAreRefused) {
  auto o = options(1);
  EXPECT_THROW(text2bfm::generate_eval_motions(*models_, {}, o), Error);
  EXPECT_THROW(text2bfm::generate_eval_motions(*models_, {{"a person walks forward", 0}}, o), Error);
  o.mm_prompts = 5;  // more than the 4 items
  EXPECT_THROW(text2bfm::generate_eval_motions(*models_, items(), o), Error);
  o.mm_prompts = 1, o.samples = 1;
  EXPECT_THROW(text2bfm::generate_eval_motions(*models_, items(), o), Error);
  o.samples = 2, o.jobs = 0;
  EXPECT_THROW(text2bfm::generate_eval_motions(*models_, items(), o), Error);
  const fs::path d = fresh_dir("bad");
  eval::MotionEntry e{"../x.npy", "a caption", -1, 1, std::vector<float>(data::kFeatureDim, 0.f)};
  EXPECT_THROW(eval::write_motion_dir((d / "m").string(), {e}), Error);
  e.file = "x.npy", e.caption = "";
  EXPECT_THROW(eval::write_motion_dir((d / "m").string(), {e}), Error);
  e.caption = "c", e.frames = 2;  // features hold one frame only
  EXPECT_THROW(eval::write_motion_dir((d / "m").string(), {e}), Error);
  EXPECT_FALSE(fs::exists(d / "m"));
  fs::remove_all(d);
}

// Table 2 runner (compose_eval.h) end to end on the tiny chain, with the tiny text-motion model standing in for
// the evaluator: rows in range, independent of the job count; the real-segment row on hand-made clips.
TEST_F(EvalGeneration, ComposeRunnerRowsAndJobIndependence) {
  std::vector<text2bfm::ComposePrompt> prompts = {
      {"a person walks forward, then someone sits down", {"a person walks forward", "someone sits down"}, {"a", "b"}},
      {"someone waves with the right hand, then a person runs in a circle",
       {"someone waves with the right hand", "a person runs in a circle"}, {"b", "a"}}};
  text2bfm::ComposeEvalOptions o;
  o.gen.steps = 2;
  o.frames_per_clause = 12;
  for (bool compose : {false, true}) {
    o.jobs = 1;
    const auto r1 = text2bfm::evaluate_compose(*models_, models_->text, prompts, o, compose);
    o.jobs = 2;
    const auto r2 = text2bfm::evaluate_compose(*models_, models_->text, prompts, o, compose);
    EXPECT_EQ(r1.method, compose ? "Text2BFM-Compose" : "Text2BFM");
    EXPECT_EQ(r1.N, 2);
    EXPECT_EQ(r1.prompts, 2);
    EXPECT_TRUE(r1.order_accuracy == 0.0 || r1.order_accuracy == 0.5 || r1.order_accuracy == 1.0);
    EXPECT_GT(r1.mm_dist, 0.0);
    EXPECT_GE(r1.transition, 0.0);
    EXPECT_EQ(r1.order_accuracy, r2.order_accuracy);
    EXPECT_EQ(r1.mm_dist, r2.mm_dist);
    EXPECT_EQ(r1.transition, r2.transition);
  }
  std::vector<data::MotionClip> clips(2);
  clips[0].name = "a", clips[1].name = "b";
  clips[0].features.assign(20 * data::kFeatureDim, 0.1f);
  clips[1].features.assign(8 * data::kFeatureDim, -0.2f);  // shorter than a clause: used whole
  const auto real = text2bfm::evaluate_real_segments(models_->text, prompts, clips, 12);
  EXPECT_EQ(real.prompts, 2);
  EXPECT_GT(real.mm_dist, 0.0);
  EXPECT_TRUE(std::isnan(real.transition));
  prompts[0].clips[0] = "missing";
  EXPECT_THROW(text2bfm::evaluate_real_segments(models_->text, prompts, clips, 12), Error);
}
