// test_io_output.cpp — models/io: OutputDir (all or nothing, overwrite, refusals) and the kinematic output
// directory of `t2m generate --model NAME` (features -> Motion -> BVH, files, bad features).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <algorithm>

#include "models/data/features.h"
#include "models/eval/motion_dir.h"
#include "models/io/kinematic_output.h"
#include "models/io/output_dir.h"
#include "sim/bvh.h"
#include "tensor/tensor.h"
#include "test_features_synthetic.h"

namespace fs = std::filesystem;
using t2m::Error;

namespace {

class IoOutput : public ::testing::Test {
 protected:
  fs::path root;
  void SetUp() override {
    root = fs::temp_directory_path() /
           ("t2m_io_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" +
            std::to_string(::getpid()));
    fs::remove_all(root);
    fs::create_directories(root);
  }
  void TearDown() override { fs::remove_all(root); }
  std::vector<std::string> entries(const fs::path& d) const {
    std::vector<std::string> out;
    for (const auto& e : fs::directory_iterator(d)) out.push_back(e.path().filename().string());
    std::sort(out.begin(), out.end());
    return out;
  }
  static void touch(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }
};

TEST_F(IoOutput, CommitMovesEverythingIntoPlace) {
  {
    t2m::io::OutputDir d((root / "out").string(), false, "test");
    touch(d.file("a.txt"), "a");
    EXPECT_FALSE(fs::exists(root / "out"));
    d.commit();
  }
  EXPECT_EQ(entries(root), std::vector<std::string>{"out"});
  EXPECT_EQ(entries(root / "out"), std::vector<std::string>{"a.txt"});
}

TEST_F(IoOutput, NoCommitLeavesNothing) {
  try {
    t2m::io::OutputDir d((root / "out").string(), false, "test");
    touch(d.file("a.txt"), "a");
    throw Error("failure half way");
  } catch (const Error&) {
  }
  EXPECT_TRUE(entries(root).empty());
}

TEST_F(IoOutput, RefusesNonEmptyTargetUnlessOverwrite) {
  fs::create_directories(root / "out");
  touch(root / "out" / "old.txt", "old");
  EXPECT_THROW(t2m::io::OutputDir((root / "out").string(), false, "test"), Error);
  {
    t2m::io::OutputDir d((root / "out").string(), true, "test");
    touch(d.file("new.txt"), "new");
    EXPECT_EQ(entries(root / "out"), std::vector<std::string>{"old.txt"});  // untouched until commit
    d.commit();
  }
  EXPECT_EQ(entries(root), std::vector<std::string>{"out"});
  EXPECT_EQ(entries(root / "out"), std::vector<std::string>{"new.txt"});
}

TEST_F(IoOutput, EmptyTargetIsReplacedAndMissingParentRefused) {
  fs::create_directories(root / "empty");
  {
    t2m::io::OutputDir d((root / "empty").string(), false, "test");
    touch(d.file("x"), "x");
    d.commit();
  }
  EXPECT_EQ(entries(root / "empty"), std::vector<std::string>{"x"});
  EXPECT_THROW(t2m::io::OutputDir((root / "no" / "such" / "out").string(), false, "test"), Error);
  EXPECT_THROW(t2m::io::OutputDir("", false, "test"), Error);
}

TEST_F(IoOutput, MotionFromFeaturesInvertsTheFeatures) {
  const auto walk = t2m::data::canonicalize_motion(t2m::testing::synthetic_walk(40));
  const auto f = t2m::data::motion_to_features(walk);
  const auto m = t2m::io::motion_from_features(f);
  ASSERT_EQ(m.frames, 40);
  EXPECT_EQ(m.offsets.size(), 63u);
  EXPECT_EQ(m.offsets, t2m::sim::humanoid_offsets());
  double max_err = 0;
  for (size_t i = 0; i < m.pos.size(); ++i) max_err = std::max(max_err, (double)std::fabs(m.pos[i] - walk.pos[i]));
  EXPECT_LT(max_err, 1e-4);
  EXPECT_THROW(t2m::io::motion_from_features({}), Error);
  EXPECT_THROW(t2m::io::motion_from_features(std::vector<float>(t2m::data::kFeatureDim + 1, 0.f)), Error);
}

TEST_F(IoOutput, KinematicGenerationWritesEveryFile) {
  t2m::io::KinematicOutput g;
  g.prompt = "a person walks forward";
  g.model = "test-model";
  g.features = t2m::data::motion_to_features(t2m::testing::synthetic_walk(30));
  g.info = {{"steps", 7}};
  t2m::io::KinematicWriteOptions w;
  w.render = false;
  auto h = t2m::sim::Humanoid::create();
  const auto metrics = t2m::io::write_kinematic_generation(g, h, (root / "walk").string(), w);
  EXPECT_EQ(entries(root), std::vector<std::string>{"walk"});
  EXPECT_EQ(entries(root / "walk"), (std::vector<std::string>{"features.npy", "metrics.json", "motion.bvh"}));
  EXPECT_EQ(metrics["frames"], 30);
  EXPECT_EQ(metrics["info"]["steps"], 7);
  EXPECT_EQ(metrics["model"], "test-model");
  // The .npy holds exactly the generated features; the BVH re-imports with the same number of frames.
  EXPECT_EQ(t2m::eval::read_npy_features((root / "walk" / "features.npy").string()), g.features);
  const auto bvh = t2m::sim::read_bvh((root / "walk" / "motion.bvh").string());
  EXPECT_EQ(t2m::sim::motion_from_bvh(bvh).frames, 30);
}

TEST_F(IoOutput, NonFiniteFeaturesWriteNothing) {
  t2m::io::KinematicOutput g;
  g.prompt = "x";
  g.features = t2m::data::motion_to_features(t2m::testing::synthetic_walk(10));
  g.features[5 * t2m::data::kFeatureDim + 3] = std::numeric_limits<float>::quiet_NaN();
  t2m::io::KinematicWriteOptions w;
  w.render = false;
  EXPECT_THROW(t2m::io::write_kinematic_generation(g, t2m::sim::Humanoid::create(), (root / "bad").string(), w),
               Error);
  EXPECT_TRUE(entries(root).empty());
}

}  // namespace
