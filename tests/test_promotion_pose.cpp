// test_promotion_pose.cpp — the PRO-Motion single-pose representation: feature <-> pose copies, joint positions,
// mirror, key frames, normalisation and bad input.
#include <gtest/gtest.h>

#include <cmath>

#include "models/data/features.h"
#include "models/data/features_mirror.h"
#include "models/promotion/pose.h"
#include "tensor/tensor.h"
#include "test_features_synthetic.h"

namespace {

using namespace t2m;
using namespace t2m::promotion;

std::vector<float> synthetic_features(int frames) {
  return data::motion_to_features(t2m::testing::synthetic_walk(frames));
}

TEST(PromotionPose, FeatureRoundTripAndJointPositions) {
  std::vector<float> f = synthetic_features(20);
  std::vector<float> p = poses_from_features(f);
  ASSERT_EQ(p.size(), 20u * kPoseDim);
  std::vector<float> row(data::kFeatureDim, -7.f);
  pose_into_features(p.data() + 5 * kPoseDim, row.data());
  for (int d = 0; d < data::kFeatureDim; ++d) {
    bool in_pose = d >= 3 && d < 190;
    EXPECT_EQ(row[d], in_pose ? f[5 * data::kFeatureDim + d] : -7.f) << d;
  }
  // Joint positions: the features' inverse gives the same positions relative to the root's ground point.
  std::vector<float> pos = data::features_to_positions(f);
  std::vector<float> j = joint_positions(p.data() + 5 * kPoseDim);
  const float* w = pos.data() + 5 * 63;
  double yaw = data::heading_yaw(w);
  EXPECT_FLOAT_EQ(j[0], 0.f);
  EXPECT_FLOAT_EQ(j[1], 0.f);
  EXPECT_NEAR(j[2], w[2], 1e-5);
  for (int k = 1; k < 21; ++k) {
    double dx = w[3 * k] - w[0], dy = w[3 * k + 1] - w[1];
    double hx = std::cos(yaw) * dx + std::sin(yaw) * dy, hy = -std::sin(yaw) * dx + std::cos(yaw) * dy;
    EXPECT_NEAR(j[3 * k], hx, 1e-4) << k;
    EXPECT_NEAR(j[3 * k + 1], hy, 1e-4) << k;
    EXPECT_NEAR(j[3 * k + 2], w[3 * k + 2], 1e-5) << k;
  }
}

TEST(PromotionPose, MirrorSwapsSidesAndIsAnInvolution) {
  std::vector<float> p = poses_from_features(synthetic_features(4));
  std::vector<float> m = mirror_poses(p);
  std::vector<float> mm = mirror_poses(m);
  for (size_t i = 0; i < p.size(); ++i) EXPECT_EQ(mm[i], p[i]);
  std::vector<float> j = joint_positions(p.data()), jm = joint_positions(m.data());
  // Hand_L (8) of the mirror = Hand_R (11) of the original with y negated.
  EXPECT_FLOAT_EQ(jm[3 * sim::kHandL], j[3 * sim::kHandR]);
  EXPECT_FLOAT_EQ(jm[3 * sim::kHandL + 1], -j[3 * sim::kHandR + 1]);
  EXPECT_FLOAT_EQ(jm[3 * sim::kHandL + 2], j[3 * sim::kHandR + 2]);
}

TEST(PromotionPose, KeyFramesEvenlySpacedWithEnds) {
  EXPECT_EQ(key_frame_indices(71, 8), (std::vector<int>{0, 10, 20, 30, 40, 50, 60, 70}));
  EXPECT_EQ(key_frame_indices(8, 8), (std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7}));
  EXPECT_EQ(key_frame_indices(3, 4), (std::vector<int>{0, 1, 1, 2}));
  EXPECT_EQ(key_frame_indices(1, 3), (std::vector<int>{0, 0, 0}));
  EXPECT_EQ(key_frame_indices(10, 1), (std::vector<int>{5}));
  std::vector<float> f = synthetic_features(15);
  std::vector<float> k = key_poses(f, 3);  // frames 0, 7, 14
  ASSERT_EQ(k.size(), 3u * kPoseDim);
  EXPECT_EQ(k[kPoseDim + 10], f[7 * data::kFeatureDim + 3 + 10]);
  EXPECT_EQ(k[2 * kPoseDim], f[14 * data::kFeatureDim + 3]);
}

TEST(PromotionPose, NormalizeRoundTrip) {
  data::FeatureStats fs;
  for (int d = 0; d < data::kFeatureDim; ++d) {
    fs.mean.push_back(0.01f * d);
    fs.std.push_back(0.5f + 0.001f * d);
  }
  PoseStats s = pose_stats_from_feature_stats(fs);
  EXPECT_FLOAT_EQ(s.mean[0], fs.mean[3]);
  EXPECT_FLOAT_EQ(s.std[kPoseDim - 1], fs.std[189]);
  std::vector<float> p = poses_from_features(synthetic_features(3)), q = p;
  normalize_poses(q, s);
  EXPECT_NEAR(q[1], (p[1] - s.mean[1]) / s.std[1], 1e-6);
  denormalize_poses(q, s);
  for (size_t i = 0; i < p.size(); ++i) EXPECT_NEAR(q[i], p[i], 1e-5);
}

TEST(PromotionPose, BadInputThrows) {
  EXPECT_THROW(key_frame_indices(0, 8), Error);
  EXPECT_THROW(key_frame_indices(10, 0), Error);
  EXPECT_THROW(poses_from_features(std::vector<float>(300)), Error);
  EXPECT_THROW(key_poses(std::vector<float>(10)), Error);
  std::vector<float> p(kPoseDim + 1);
  PoseStats s{std::vector<float>(kPoseDim, 0.f), std::vector<float>(kPoseDim, 1.f)};
  EXPECT_THROW(normalize_poses(p, s), Error);
  std::vector<float> ok(kPoseDim);
  EXPECT_THROW(normalize_poses(ok, PoseStats{}), Error);
  EXPECT_THROW(pose_stats_from_feature_stats(data::FeatureStats{}), Error);
  EXPECT_THROW(mirror_poses(p), Error);
}

}  // namespace
