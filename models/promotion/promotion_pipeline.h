// promotion_pipeline.h — the whole PRO-Motion baseline (Fig 3): text -> planner (K posture scripts, planner.h) ->
// posture diffuser (N candidate poses per script, posture_diffuser_sampler.h) -> posture planning (Viterbi over
// the emission / transition scores of the pose-text encoders, pose_text_encoders.h + viterbi.h) -> key poses ->
// go-diffuser (go_diffuser.h) -> raw motion features [T, 257].
//
// Files in the checkpoints directory: promotion_planner.json, promotion_posture.t2mckpt, promotion_encoders.t2mckpt,
// promotion_go.t2mckpt. Each stage's pose normalisation comes from its own file (they are all train-split stats).
// Length: the go-diffuser's window (T = 64 frames = 2.13 s at 30 fps, K = 8 key poses) is one unit. A longer
// request chains W = max(1, round((frames - 1) / (T - 1))) windows that share their boundary key pose (ours; the
// paper generates one window): the planner is asked for W (K - 1) + 1 scripts, Viterbi picks one pose per key over
// the whole chain, window w takes keys w (K - 1) .. w (K - 1) + K - 1 and its own noise (seed + 1 + w), and the
// windows' features are concatenated with each later window's first frame (the shared key frame) dropped:
// W (T - 1) + 1 frames. The key poses go to the frames of pose.h's rule. Heading and position start at the origin
// facing +X (features carry no absolute pose; root motion is velocity-coded, so windows join without a jump).
// Determinism: every random draw comes from the seed (posture sampling: seed; go-diffuser: seed + 1).
// Errors (t2m::Error): a missing checkpoint file (named, with the command that makes it), and those of the stages.
#pragma once
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/promotion/go_diffuser_checkpoint.h"
#include "models/promotion/planner_table.h"
#include "models/promotion/pose_text_encoders.h"
#include "models/promotion/posture_diffuser_sampler.h"

namespace t2m::promotion {

struct PromotionModels {
  PlannerTable planner;
  PostureModel posture;
  PoseTextBundle encoders;
  GoBundle go;
};
PromotionModels load_promotion_models(const std::string& checkpoints_dir);

struct PromotionOptions {
  int candidates = 8;            // N poses sampled per script
  double posture_guidance = 1.25; // posture diffuser CFG w: best posecode agreement on the VAL split (PROMOTION.md §4)
  int posture_steps = 50;        // posture sampling steps: 0 = all T (DDPM), else strided DDIM (eta 1)
  double go_guidance = 1.0;      // go-diffuser CFG w (1 = conditional only)
  bool go_inpaint = true;        // key-pose inpainting in the go-diffuser's sampler (go_diffuser.h; ours)
  int64_t frames = 0;            // requested length in frames: 0 = one go-diffuser window (see above)
  uint64_t seed = 0;
};

// Posture planning: candidates (K, N, 187) RAW poses -> the Viterbi path and the chosen raw poses (K, 187).
struct PostureChoice {
  std::vector<int> path;        // (K)
  double score = 0;             // log P(G)
  std::vector<float> poses;     // (K, 187) raw
};
PostureChoice plan_key_poses(const PoseTextBundle& enc, const std::vector<float>& candidates, int K, int N,
                             const std::vector<std::string>& scripts);

// The go stage alone: K raw key poses (K, 187) -> raw features [T, 257] (one DDPM sample).
std::vector<float> go_from_key_poses(const GoBundle& go, const std::vector<float>& key_poses, uint64_t seed,
                                     double guidance = 1.0, bool inpaint = false);

struct PromotionResult {
  std::vector<float> features;  // [T, 257] raw
  std::vector<std::string> scripts;
  PostureChoice choice;
  nlohmann::json info;          // plan clauses, path, scores, options
};
PromotionResult generate_promotion(const PromotionModels& m, const std::string& prompt, const PromotionOptions& o);

}  // namespace t2m::promotion
