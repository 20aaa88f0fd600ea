// test_loader_compose.cpp — "A, then B" samples: root/heading alignment, continuity at the seam, captions.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "models/data/captions.h"
#include "models/data/compose_samples.h"
#include "models/data/features.h"
#include "models/data/features_math.h"
#include "models/data/features_mirror.h"
#include "sim/bvh.h"
#include "test_features_synthetic.h"

using namespace t2m::data;
using t2m::testing::synthetic_walk;

namespace {

constexpr int J = 21;

// Largest per-frame displacement of any joint (metres) over frames [t0, t1) (step t-1 -> t).
double max_step(const t2m::sim::Motion& m, int t0, int t1, bool root_only = false) {
  double best = 0;
  for (int t = std::max(t0, 1); t < t1; ++t)
    for (int j = 0; j < (root_only ? 1 : J); ++j) {
      double s = 0;
      for (int k = 0; k < (root_only ? 2 : 3); ++k) {
        double d = m.pos[((size_t)t * J + j) * 3 + k] - m.pos[((size_t)(t - 1) * J + j) * 3 + k];
        s += d * d;
      }
      best = std::max(best, std::sqrt(s));
    }
  return best;
}

double dist(const t2m::sim::Motion& m, int t, int a, int b) {
  double s = 0;
  for (int k = 0; k < 3; ++k) {
    double d = m.pos[((size_t)t * J + a) * 3 + k] - m.pos[((size_t)t * J + b) * 3 + k];
    s += d * d;
  }
  return std::sqrt(s);
}

}  // namespace

TEST(Compose, AlignsRootAndHeadingAndIsContinuousAtTheSeam) {
  // A walks from the origin facing 0.3 rad; B starts 40 m away facing the other way, turning the other way.
  auto a = synthetic_walk(90, 0.3, 0.0, 0.0, 0.2, 1.2);
  auto b = synthetic_walk(70, 2.9, 40.0, -25.0, -0.3, 1.0);
  const int K = 10, s = 90 - K;
  auto c = compose_motions(a, b, K);
  ASSERT_EQ(c.frames, 90 + 70 - K);
  // Before the blend: exactly A.
  for (size_t i = 0; i < (size_t)s * J * 3; ++i) ASSERT_EQ(c.pos[i], a.pos[i]);
  // After the blend: B moved rigidly (distances kept) with heading offset heading(A[s]) - heading(B[0]).
  const double dyaw = heading_yaw(&a.pos[(size_t)s * J * 3]) - heading_yaw(b.pos.data());
  for (int t = 90; t < c.frames; t += 7) {
    const int tb = t - s;
    EXPECT_NEAR(fm::wrap_angle(heading_yaw(&c.pos[(size_t)t * J * 3]) - heading_yaw(&b.pos[(size_t)tb * J * 3]) - dyaw),
                0.0, 1e-5);
    EXPECT_NEAR(dist(c, t, t2m::sim::kHandL, t2m::sim::kToesR), dist(b, tb, t2m::sim::kHandL, t2m::sim::kToesR), 1e-5);
    for (int k = 2; k < J * 3; k += 3) EXPECT_EQ(c.pos[(size_t)t * J * 3 + k], b.pos[(size_t)tb * J * 3 + k]);
  }
  // Continuity: the root never jumps more than the larger root step of A and B (times 1.1); every joint's step
  // in the blend window stays within the larger step of A/B plus 3 cm. A hard cut without alignment jumps > 1 m.
  const double root_ab = std::max(max_step(a, 0, a.frames, true), max_step(b, 0, b.frames, true));
  EXPECT_LT(max_step(c, 0, c.frames, true), 1.1 * root_ab);
  const double joint_ab = std::max(max_step(a, 0, a.frames), max_step(b, 0, b.frames));
  EXPECT_LT(max_step(c, s - 1, 90 + 2), joint_ab + 0.03);
  t2m::sim::Motion naive = a;
  naive.frames += b.frames;
  naive.pos.insert(naive.pos.end(), b.pos.begin(), b.pos.end());
  EXPECT_GT(max_step(naive, 89, 91, true), 1.0);
  // Rotations stay unit quaternions.
  for (size_t i = 0; i < c.rot.size(); i += 4) {
    double n = 0;
    for (int k = 0; k < 4; ++k) n += c.rot[i + k] * c.rot[i + k];
    ASSERT_NEAR(n, 1.0, 1e-5);
  }
}

TEST(Compose, ClipsGetThenCaptionsAndExactFeatures) {
  auto a = make_motion_clip("dataset-2_walk_elderly_001", "walk", "elderly", synthetic_walk(80));
  auto b = make_motion_clip("dataset-2_wave-left-hand_active_002", "wave-left-hand", "active",
                            synthetic_walk(50, 1.0, 2.0, 2.0, 0.0, 0.5));
  auto c = compose_clips(a, b, 7, 3);
  EXPECT_EQ(c.frames, 80 + 50 - kDefaultBlendFrames);
  EXPECT_EQ(c.features.size(), (size_t)c.frames * kFeatureDim);
  EXPECT_EQ(c.name, a.name + "+" + b.name);
  EXPECT_EQ(c.caption, make_caption("walk", "elderly", 7, 6).text + ", then " +
                           make_caption("wave-left-hand", "active", 7, 7).text);
  // Features of the composition are the features of the composed canonical motions.
  auto want = compose_motions(clip_to_motion(a), clip_to_motion(b), kDefaultBlendFrames);
  auto f = motion_to_features(want);
  double err = 0;
  for (size_t i = 0; i < f.size(); ++i) err = std::max(err, (double)std::fabs(f[i] - c.features[i]));
  EXPECT_LT(err, 1e-6);
  // The first part of the composed features is the first clip's (frame 0..s-1 except contacts near the end,
  // which depend on the lowest foot height over the clip).
  for (int t = 1; t < 60; ++t)
    for (int d = 0; d < kFeatContact; ++d) ASSERT_NEAR(c.features[t * kFeatureDim + d], a.features[t * kFeatureDim + d], 1e-4);
  // A composed clip with a fixed caption composes again: "A, then B, then C".
  auto cc = compose_clips(c, a, 7, 4);
  EXPECT_EQ(cc.caption.rfind(c.caption + ", then ", 0), 0u);
}

TEST(Compose, ManyPairsDeterministic) {
  std::vector<MotionClip> clips;
  const char* contents[] = {"walk", "run", "bow", "kick"};
  for (int i = 0; i < 4; ++i)
    clips.push_back(make_motion_clip("c" + std::to_string(i), contents[i], "normal", synthetic_walk(40 + 10 * i, i)));
  clips.push_back(make_motion_clip("short", "walk", "normal", synthetic_walk(8)));  // too short for a blend of 10
  auto x = make_composed_clips(clips, 6, 3), y = make_composed_clips(clips, 6, 3);
  ASSERT_EQ(x.size(), 6u);
  for (int k = 0; k < 6; ++k) {
    EXPECT_EQ(x[k].caption, y[k].caption);
    EXPECT_EQ(x[k].features, y[k].features);
    EXPECT_EQ(x[k].name.find("short"), std::string::npos);
    auto plus = x[k].name.find('+');
    ASSERT_NE(plus, std::string::npos);
    EXPECT_NE(x[k].name.substr(0, plus), x[k].name.substr(plus + 1));
  }
  EXPECT_TRUE(make_composed_clips(clips, 0, 1).empty());
}

TEST(Compose, BadInputThrows) {
  auto a = synthetic_walk(20), b = synthetic_walk(15);
  EXPECT_THROW(compose_motions(a, b, 0), t2m::Error);
  EXPECT_THROW(compose_motions(a, b, 15), t2m::Error);
  EXPECT_THROW(compose_motions(a, b, -2), t2m::Error);
  auto c = b;
  c.fps = 60;
  EXPECT_THROW(compose_motions(a, c, 5), t2m::Error);
  std::vector<MotionClip> shorts = {make_motion_clip("s", "walk", "normal", synthetic_walk(5))};
  EXPECT_THROW(make_composed_clips(shorts, 1, 0), t2m::Error);
  EXPECT_THROW(make_composed_clips(shorts, -1, 0), t2m::Error);
  MotionClip broken;
  broken.frames = 3;
  EXPECT_THROW(clip_to_motion(broken), t2m::Error);
}

TEST(Compose, RealWalkThenMirroredWalkIsContinuous) {
  // The committed 60-frame Bandai walk, followed by its mirror image turned by 1 rad and moved 5 m away.
  auto a = t2m::sim::motion_from_bvh(
      t2m::sim::read_bvh(std::string(T2M_SOURCE_DIR) + "/tests/fixtures/bvh/bandai_walk_60.bvh"));
  auto b = mirror_motion(a);
  transform_motion(b, 1.0, 5.0, 3.0);
  auto c = compose_motions(a, b, kDefaultBlendFrames);
  ASSERT_EQ(c.frames, 120 - kDefaultBlendFrames);
  const double root_ab = std::max(max_step(a, 0, a.frames, true), max_step(b, 0, b.frames, true));
  const double joint_ab = std::max(max_step(a, 0, a.frames), max_step(b, 0, b.frames));
  EXPECT_LT(max_step(c, 0, c.frames, true), 1.1 * root_ab);
  EXPECT_LT(max_step(c, 0, c.frames), joint_ab + 0.03);
  // The features of the composition invert back to it (canonical frame) under 1 mm.
  auto f = motion_to_features(c);
  auto p = features_to_positions(f);
  auto want = canonicalize_motion(c).pos;
  double err = 0;
  for (size_t i = 0; i < p.size(); ++i) err = std::max(err, (double)std::fabs(p[i] - want[i]));
  EXPECT_LT(err, 1e-3);
}
