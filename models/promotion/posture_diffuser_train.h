// posture_diffuser_train.h — training the posture diffuser on (key pose, posture script) pairs (`t2m train
// promotion --variant posture`): PRO-Motion appendix D (AdamW, x_0 prediction with the simple objective, paper
// Eq 2; condition dropout 10% for classifier-free guidance) on our PoseScript-style set (posture_script_set.h).
//
// One step: B items drawn uniformly (with replacement) from rng "data"; t ~ U{0..T-1} and eps ~ N(0, I) from rng
// "noise" (x_t = q_sample(x_0, t, eps), diffusion_schedule.h); dropped conditions from rng "drop";
// loss = mean over items and pose dims of (f(x_t, t, c) - x_0)^2 (paper Eq 2, nn::mse_loss; the paper's squared
// norm divided by kPoseDim). AdamW (no decay on 1-D parameters), warm-up + cosine to lr/10, gradient clipping at 1.
// Resumable: nn::TrainState at paths.state every save_every steps and at the end; stop_at > 0 ends the run
// (resumably) after that many steps in total; a stopped and resumed run equals a straight one for the same thread
// count. JSONL log (step, loss, lr, grad_norm) and an SVG plot.
// posture_eval_loss: the same loss on the first max_items items of a set with t and eps drawn from Generator(seed)
// (fixed per item), no condition dropout, no gradient: the comparable number for val/test.
// Errors (t2m::Error "posture train: ..."): bad config, empty data, mismatched sizes.
#pragma once
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "models/promotion/pose.h"
#include "models/promotion/posture_diffuser.h"
#include "models/promotion/posture_script_set.h"
#include "models/text/tokenizer.h"
#include "nn/train_config.h"

namespace t2m::promotion {

struct PostureTrainConfig : nn::TrainLoopConfig {
  PostureTrainConfig() { steps = 3000, batch = 128, lr = 5e-4, warmup = 100, save_every = 250; }
  nlohmann::json to_json() const { return common_json(); }
  void validate() const { validate_common("posture train", to_json()); }
};

// Normalised key poses and tokenised scripts of a set.
struct PostureTrainData {
  Tensor x0;    // (N, kPoseDim) float32, normalised
  Tensor ids;   // (N, L) int64
  Tensor mask;  // (N, L) float32
  int64_t size() const { return x0.defined() ? x0.size(0) : 0; }
};
PostureTrainData make_posture_train_data(const PostureScriptSet& s, const PoseStats& stats,
                                         const text::Tokenizer& tok, int64_t max_tokens);

using PostureTrainPaths = nn::TrainPaths;

using PostureTrainResult = nn::TrainRunResult;

PostureTrainResult train_posture_diffuser(PostureDiffuser& net, const PostureTrainData& data,
                                          const PostureTrainConfig& cfg, const PostureTrainPaths& paths, bool resume);

double posture_eval_loss(const PostureDiffuser& net, const PostureTrainData& data, int64_t max_items, uint64_t seed,
                         int64_t batch = 256);

}  // namespace t2m::promotion
