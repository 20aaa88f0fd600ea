// test_promotion_pipeline.cpp — the whole PRO-Motion baseline on the shipped checkpoints (models/checkpoints/
// promotion_*): text -> planner -> posture diffuser (strided DDIM) -> Viterbi -> go-diffuser. Checks the output
// length rule (one window by default; chained windows sharing their boundary key pose for longer requests),
// determinism for a seed, that the chained motion passes through the chosen key poses at the key frames of every
// window (key-pose inpainting), and bad inputs. Skipped when the
// shipped files are absent.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "models/data/features.h"
#include "models/promotion/pose.h"
#include "models/promotion/promotion_pipeline.h"

namespace {

using namespace t2m;
using namespace t2m::promotion;

const PromotionModels* shipped() {
  static const std::string dir = std::string(T2M_SOURCE_DIR) + "/models/checkpoints";
  static const bool ok = std::filesystem::exists(dir + "/promotion_go.t2mckpt") &&
                         std::filesystem::exists(dir + "/promotion_posture.t2mckpt");
  static const PromotionModels m = ok ? load_promotion_models(dir) : PromotionModels{};
  return ok ? &m : nullptr;
}

// RMS difference (normalised by nothing: raw metres / rotation units) between the key poses Viterbi chose and the
// generated motion's pose at the corresponding frames.
double key_pose_error(const PromotionResult& r, int K, int T) {
  const int keys = (int)r.choice.path.size(), W = (keys - 1) / (K - 1);
  const std::vector<int> kf = key_frame_indices(T, K);
  double e = 0;
  int n = 0;
  for (int i = 0; i < keys; ++i) {
    const int w = std::min(i / (K - 1), W - 1), j = i - w * (K - 1);
    const int64_t frame = (int64_t)w * (T - 1) + kf[j];
    const std::vector<float> p = pose_from_features(r.features.data() + frame * data::kFeatureDim);
    for (int d = 0; d < 61; ++d) {  // root height + joint positions (the 6D rotations are scaled differently)
      e += std::pow(p[d] - r.choice.poses[(size_t)i * kPoseDim + d], 2);
      ++n;
    }
  }
  return std::sqrt(e / n);
}

TEST(PromotionPipeline, LengthChainingDeterminismAndKeyPoses) {
  const PromotionModels* m = shipped();
  if (!m) GTEST_SKIP() << "no shipped promotion checkpoints";
  const int K = (int)m->go.model->config().keys, T = (int)m->go.model->config().frames;
  PromotionOptions o;
  o.candidates = 3;
  o.posture_steps = 10;
  o.seed = 3;
  const PromotionResult one = generate_promotion(*m, "a person walks forward", o);
  EXPECT_EQ((int)one.features.size(), T * data::kFeatureDim);
  EXPECT_EQ((int)one.choice.path.size(), K);
  EXPECT_EQ(one.info["go_windows"], 1);
  EXPECT_EQ(generate_promotion(*m, "a person walks forward", o).features, one.features);  // deterministic

  o.frames = 128;  // -> 2 windows, 15 keys, 127 frames
  const PromotionResult two = generate_promotion(*m, "a person walks forward", o);
  EXPECT_EQ((int)two.features.size(), (2 * (T - 1) + 1) * data::kFeatureDim);
  EXPECT_EQ((int)two.choice.path.size(), 2 * (K - 1) + 1);
  EXPECT_EQ((int)two.scripts.size(), 2 * (K - 1) + 1);
  EXPECT_EQ(two.info["go_windows"], 2);
  for (float f : two.features) ASSERT_TRUE(std::isfinite(f));
  EXPECT_EQ(two.choice.poses.size(), two.choice.path.size() * kPoseDim);
  // With key-pose inpainting (the default) every window passes through its key poses exactly, so the chosen key
  // poses reappear at frame w (T - 1) + rule(j) of the chained motion; a misaligned chain would be far off.
  ASSERT_TRUE(o.go_inpaint);
  const double e1 = key_pose_error(one, K, T), e2 = key_pose_error(two, K, T);
  EXPECT_LT(e1, 1e-3);
  EXPECT_LT(e2, 1e-3);
  std::printf("key-pose RMS error: one window %.2e, two windows %.2e\n", e1, e2);
  // Short requests still give one full window; 190 frames -> 3 windows.
  o.frames = 10;
  EXPECT_EQ((int)generate_promotion(*m, "a person waves", o).features.size(), T * data::kFeatureDim);
  o.frames = 190;
  EXPECT_EQ((int)generate_promotion(*m, "a person waves", o).features.size(), (3 * (T - 1) + 1) * data::kFeatureDim);
  o.frames = -1;
  EXPECT_THROW(generate_promotion(*m, "a person waves", o), Error);
  o.frames = 0;
  o.candidates = 0;
  EXPECT_THROW(generate_promotion(*m, "a person waves", o), Error);
}

}  // namespace
