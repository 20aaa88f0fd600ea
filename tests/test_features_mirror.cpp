// test_features_mirror.cpp — left/right mirroring of motions and feature rows.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "models/data/features.h"
#include "models/data/features_mirror.h"
#include "tensor/tensor.h"
#include "test_features_synthetic.h"

using namespace t2m::data;
namespace sim = t2m::sim;
using t2m::testing::synthetic_walk;

TEST(FeaturesMirror, TwiceIsIdentityBitExact) {
  auto m = synthetic_walk(45);
  auto mm = mirror_motion(mirror_motion(m));
  EXPECT_EQ(mm.pos, m.pos);
  EXPECT_EQ(mm.rot, m.rot);
  EXPECT_EQ(mm.offsets, m.offsets);
  auto f = motion_to_features(m);
  EXPECT_EQ(mirror_features(mirror_features(f)), f);
}

TEST(FeaturesMirror, ReflectsAndSwapsJoints) {
  auto m = synthetic_walk(10);
  auto r = mirror_motion(m);
  for (int t = 0; t < 10; ++t) {
    auto P = [&](const sim::Motion& x, int j, int k) { return x.pos[(t * 21 + j) * 3 + k]; };
    // The mirrored left hand is the reflected right hand, and the centre joints stay centre joints.
    EXPECT_EQ(P(r, sim::kHandL, 0), P(m, sim::kHandR, 0));
    EXPECT_EQ(P(r, sim::kHandL, 1), -P(m, sim::kHandR, 1));
    EXPECT_EQ(P(r, sim::kToesR, 2), P(m, sim::kToesL, 2));
    EXPECT_EQ(P(r, sim::kHead, 1), -P(m, sim::kHead, 1));
  }
  // A motion turning left (yaw increasing) mirrors into one turning right.
  auto f = motion_to_features(m), fr = motion_to_features(r);
  double turn = 0, turn_r = 0;
  for (int t = 1; t < 10; ++t) { turn += f[t * kFeatureDim]; turn_r += fr[t * kFeatureDim]; }
  EXPECT_GT(turn, 0.01);
  EXPECT_NEAR(turn_r, -turn, 1e-6);
}

TEST(FeaturesMirror, MirroredMotionKeepsTheForwardKinematicsInvariant) {
  // pos of the mirror equals FK(mirrored rot, mirrored offsets): rotations were mirrored consistently.
  auto r = mirror_motion(synthetic_walk(30));
  auto fk = r;
  t2m::testing::synth_fk(fk);
  double err = 0;
  for (size_t i = 0; i < r.pos.size(); ++i) err = std::max(err, (double)std::fabs(fk.pos[i] - r.pos[i]));
  EXPECT_LT(err, 1e-5);
}

TEST(FeaturesMirror, FeatureSpaceMirrorEqualsRecomputedFeatures) {
  auto m = synthetic_walk(200);
  auto via_motion = motion_to_features(mirror_motion(m));
  auto via_features = mirror_features(motion_to_features(m));
  ASSERT_EQ(via_motion.size(), via_features.size());
  double err = 0;
  for (size_t i = 0; i < via_motion.size(); ++i) err = std::max(err, (double)std::fabs(via_motion[i] - via_features[i]));
  EXPECT_LT(err, 2e-5);
  // And the inverse of the mirrored features is the mirrored canonical motion.
  auto pos = features_to_positions(via_features);
  auto want = canonicalize_motion(mirror_motion(m)).pos;
  double perr = 0;
  for (size_t i = 0; i < pos.size(); ++i) perr = std::max(perr, (double)std::fabs(pos[i] - want[i]));
  EXPECT_LT(perr, 1e-4);
}

TEST(FeaturesMirror, BadInputThrows) {
  EXPECT_THROW(mirror_features(std::vector<float>(kFeatureDim - 1)), t2m::Error);
  auto m = synthetic_walk(3);
  m.rot.pop_back();
  EXPECT_THROW(mirror_motion(m), t2m::Error);
}
