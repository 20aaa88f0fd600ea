// test_features.cpp — feature layout, exact inverse (< 1 mm), invariances, hand-computed values, bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "models/data/features.h"
#include "models/data/features_math.h"
#include "tensor/tensor.h"
#include "test_features_synthetic.h"

using namespace t2m::data;
using t2m::testing::synthetic_stand;
using t2m::testing::synthetic_walk;

namespace {

double max_abs_diff(const std::vector<float>& a, const std::vector<float>& b) {
  EXPECT_EQ(a.size(), b.size());
  double m = 0;
  for (size_t i = 0; i < a.size() && i < b.size(); ++i) m = std::max(m, std::fabs((double)a[i] - b[i]));
  return m;
}

// Max joint position error in metres (Euclidean per joint).
double max_joint_err(const std::vector<float>& a, const std::vector<float>& b) {
  double m = 0;
  for (size_t i = 0; i + 2 < a.size(); i += 3) {
    double dx = a[i] - b[i], dy = a[i + 1] - b[i + 1], dz = a[i + 2] - b[i + 2];
    m = std::max(m, std::sqrt(dx * dx + dy * dy + dz * dz));
  }
  return m;
}

// |q1 . q2| close to 1 means the same rotation.
double max_quat_err(const std::vector<float>& a, const std::vector<float>& b) {
  double m = 0;
  for (size_t i = 0; i + 3 < a.size(); i += 4) {
    double na = 0, nb = 0, d = 0;
    for (int k = 0; k < 4; ++k) { d += a[i + k] * b[i + k]; na += a[i + k] * a[i + k]; nb += b[i + k] * b[i + k]; }
    m = std::max(m, 1.0 - std::fabs(d) / std::sqrt(na * nb));
  }
  return m;
}

}  // namespace

static_assert(kFeatRootVel == kFeatRootYawVel + 1 && kFeatRootHeight == kFeatRootVel + 2);
static_assert(kFeatLocalPos == kFeatRootHeight + 1 && kFeatRot6d == kFeatLocalPos + 20 * 3);
static_assert(kFeatJointVel == kFeatRot6d + 21 * 6 && kFeatContact == kFeatJointVel + 21 * 3);
static_assert(kFeatureDim == kFeatContact + 4 && kFeatureDim == 257);

TEST(Features, HeadingOfRestPoses) {
  // Rest pose: left side on +Y, so the figure faces +X (yaw 0); turned by yaw a, heading_yaw returns a.
  for (double a : {0.0, 0.7, -2.0, 3.0}) {
    auto m = synthetic_stand(1, a);
    EXPECT_NEAR(fm::wrap_angle(heading_yaw(m.pos.data()) - a), 0.0, 1e-6) << a;
  }
  // Degenerate pose (all joints at one point): the fallback is returned.
  std::vector<float> zero(63, 0.0f);
  EXPECT_EQ(heading_yaw(zero.data(), 1.25), 1.25);
}

TEST(Features, RoundTripSyntheticUnderOneMillimetre) {
  for (int frames : {2, 90, 1800}) {
    auto m = synthetic_walk(frames);
    auto f = motion_to_features(m);
    ASSERT_EQ(f.size(), (size_t)frames * kFeatureDim);
    auto canon = canonicalize_motion(m);
    auto pos = features_to_positions(f);
    double err = max_joint_err(pos, canon.pos);
    EXPECT_LT(err, 1e-3) << frames << " frames";
    EXPECT_LT(err, 1e-4) << frames << " frames (double integration should be far below 1 mm)";
    EXPECT_LT(max_quat_err(features_to_rotations(f), canon.rot), 1e-6) << frames;
  }
}

TEST(Features, CanonicalFrameIsARigidMotionToOriginFacingX) {
  auto m = synthetic_walk(60);
  auto c = canonicalize_motion(m);
  EXPECT_NEAR(c.pos[0], 0.0, 1e-6);
  EXPECT_NEAR(c.pos[1], 0.0, 1e-6);
  EXPECT_NEAR(heading_yaw(c.pos.data()), 0.0, 1e-5);
  // Pairwise distances between (frame 0 root, frame 59 hand) etc. are preserved.
  auto dist = [](const std::vector<float>& p, size_t a, size_t b) {
    double s = 0;
    for (int k = 0; k < 3; ++k) s += (p[3 * a + k] - p[3 * b + k]) * (p[3 * a + k] - p[3 * b + k]);
    return std::sqrt(s);
  };
  for (size_t a : {0ul, 8ul, 21ul * 30 + 12, 21ul * 59 + 20})
    for (size_t b : {5ul, 21ul * 59 + 0, 21ul * 45 + 16}) EXPECT_NEAR(dist(c.pos, a, b), dist(m.pos, a, b), 2e-5);
  // Heights are untouched.
  for (size_t i = 2; i < m.pos.size(); i += 3) ASSERT_EQ(c.pos[i], m.pos[i]);
}

TEST(Features, InvariantToWorldYawAndTranslation) {
  auto m = synthetic_walk(120);
  auto moved = m;
  transform_motion(moved, 1.1, 5.0, -7.0);
  EXPECT_LT(max_abs_diff(motion_to_features(m), motion_to_features(moved)), 5e-5);
}

TEST(Features, HandComputedStraightWalk) {
  // The rest pose facing +Y (yaw pi/2) translated by 0.05 m per frame along +Y, no rotation change:
  // root velocity in the heading frame is (0.05, 0), yaw velocity 0, joint velocities (0.05, 0, 0),
  // local positions are the rest offsets (the figure is built facing +X), contacts 0 (1.5 m/s > 0.6 m/s).
  auto m = synthetic_stand(10, M_PI / 2);
  auto rest = synthetic_stand(1, 0.0);
  for (int t = 0; t < 10; ++t)
    for (int j = 0; j < 21; ++j) m.pos[(t * 21 + j) * 3 + 1] += 0.05f * t;
  auto f = motion_to_features(m);
  for (int t = 0; t < 10; ++t) {
    const float* r = &f[t * kFeatureDim];
    EXPECT_NEAR(r[kFeatRootYawVel], 0.0, 1e-6);
    EXPECT_NEAR(r[kFeatRootVel], 0.05, 1e-6);
    EXPECT_NEAR(r[kFeatRootVel + 1], 0.0, 1e-6);
    EXPECT_NEAR(r[kFeatRootHeight], 0.95, 1e-6);
    for (int j = 1; j < 21; ++j) {
      EXPECT_NEAR(r[kFeatLocalPos + 3 * (j - 1) + 0], rest.pos[3 * j + 0] - rest.pos[0], 1e-5);
      EXPECT_NEAR(r[kFeatLocalPos + 3 * (j - 1) + 1], rest.pos[3 * j + 1] - rest.pos[1], 1e-5);
      EXPECT_NEAR(r[kFeatLocalPos + 3 * (j - 1) + 2], rest.pos[3 * j + 2], 1e-6);
    }
    for (int j = 0; j < 21; ++j) {
      EXPECT_NEAR(r[kFeatJointVel + 3 * j], 0.05, 1e-5);
      EXPECT_NEAR(r[kFeatJointVel + 3 * j + 1], 0.0, 1e-5);
      // Identity in the heading frame -> 6D (1,0,0, 0,1,0) for every joint (root yaw removed).
      const float want[6] = {1, 0, 0, 0, 1, 0};
      for (int k = 0; k < 6; ++k) EXPECT_NEAR(r[kFeatRot6d + 6 * j + k], want[k], 1e-6) << j << " " << k;
    }
    for (int k = 0; k < 4; ++k) EXPECT_EQ(r[kFeatContact + k], 0.0f);
  }
}

TEST(Features, ContactsStandingAndLiftedFoot) {
  // Standing still: every foot joint is at its lowest point with zero speed -> all contacts 1.
  auto m = synthetic_stand(20, 0.3);
  auto f = motion_to_features(m);
  for (int t = 0; t < 20; ++t)
    for (int k = 0; k < 4; ++k) EXPECT_EQ(f[t * kFeatureDim + kFeatContact + k], 1.0f);
  // Left foot and toes lifted 0.2 m on frames 10..19 (a step up at frame 10): no left contact there; the right
  // side keeps contact.
  for (int t = 10; t < 20; ++t)
    for (int j : {(int)t2m::sim::kFootL, (int)t2m::sim::kToesL}) m.pos[(t * 21 + j) * 3 + 2] += 0.2f;
  f = motion_to_features(m);
  for (int t = 10; t < 20; ++t) {
    EXPECT_EQ(f[t * kFeatureDim + kFeatContact + 0], 0.0f) << t;
    EXPECT_EQ(f[t * kFeatureDim + kFeatContact + 1], 0.0f) << t;
    EXPECT_EQ(f[t * kFeatureDim + kFeatContact + 2], 1.0f) << t;
    EXPECT_EQ(f[t * kFeatureDim + kFeatContact + 3], 1.0f) << t;
  }
  // A foot sliding at 1.5 m/s on the floor is not in contact (speed threshold).
  auto s = synthetic_stand(5, 0.0);
  for (int t = 0; t < 5; ++t) s.pos[(t * 21 + 19) * 3 + 0] += 0.05f * t;
  f = motion_to_features(s);
  for (int t = 0; t < 5; ++t) EXPECT_EQ(f[t * kFeatureDim + kFeatContact + 2], 0.0f) << t;
}

TEST(Features, BadInputThrows) {
  auto m = synthetic_walk(5);
  auto bad = m;
  bad.pos.pop_back();
  EXPECT_THROW(motion_to_features(bad), t2m::Error);
  bad = m;
  bad.rot.resize(7);
  EXPECT_THROW(motion_to_features(bad), t2m::Error);
  bad = m;
  bad.frames = 0;
  bad.pos.clear();
  bad.rot.clear();
  EXPECT_THROW(motion_to_features(bad), t2m::Error);
  bad = m;
  bad.fps = 0;
  EXPECT_THROW(motion_to_features(bad), t2m::Error);
  EXPECT_THROW(features_to_positions(std::vector<float>(kFeatureDim + 1)), t2m::Error);
  EXPECT_THROW(features_to_positions({}), t2m::Error);
  EXPECT_THROW(features_to_rotations(std::vector<float>(3)), t2m::Error);
  EXPECT_THROW(canonicalize_motion(bad), t2m::Error);
}

TEST(Features, SingleFrameClip) {
  auto m = synthetic_walk(1);
  auto f = motion_to_features(m);
  EXPECT_EQ(f[kFeatRootYawVel], 0.0f);
  EXPECT_EQ(f[kFeatRootVel], 0.0f);
  EXPECT_LT(max_joint_err(features_to_positions(f), canonicalize_motion(m).pos), 1e-5);
}
