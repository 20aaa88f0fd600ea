// pose_text_encoders_train.h — contrastive training of the posture-planning encoders (`t2m train promotion
// --variant encoders`) on our PoseScript-style set (posture_script_set.h: the 8 key poses of every train clip and
// of its mirror, each with its automatic posture script), and their retrieval accuracy on another split's set.
//
// One step: B items drawn uniformly with replacement (rng "data"); poses normalised with the train pose stats;
// scripts tokenised with the script tokenizer (cut to the batch's longest); loss = nn::info_nce(Θ(p), Φ(s), α,
// script ids) — items with the identical script text are false negatives and left out of the denominators; AdamW
// (no decay on 1-D parameters), warm-up + cosine learning rate, gradient clipping at 1, α clamped after each step.
// Resumable like the other trainers (nn::TrainState at paths.state every save_every steps and at the end).
// Retrieval (pose_text_retrieval): items in fixed groups of `group` (in set order, last partial group dropped);
// pose -> script top-1: the best-scoring script of the group has the pose's own script text (duplicates count).
// Errors (t2m::Error, "encoders train: ..."): bad config, an empty set.
#pragma once
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "models/promotion/pose_text_encoders.h"
#include "models/promotion/posture_script_set.h"
#include "nn/train_config.h"

namespace t2m::promotion {

struct EncodersTrainConfig : nn::TrainLoopConfig {
  EncodersTrainConfig() { steps = 600, batch = 64, lr = 1e-3, warmup = 50, save_every = 100; }
  nlohmann::json to_json() const { return common_json(); }
  void validate() const { validate_common("encoders train", to_json(), 2); }
};

using EncodersTrainPaths = nn::TrainPaths;

using EncodersTrainResult = nn::TrainRunResult;

EncodersTrainResult train_pose_text_encoders(PoseTextEncoders& m, const text::Tokenizer& tok,
                                             const PostureScriptSet& set, const PoseStats& stats,
                                             const EncodersTrainConfig& cfg, const EncodersTrainPaths& paths,
                                             bool resume, const std::string& label = "train promotion encoders");

struct RetrievalResult {
  double pose_to_script_top1 = 0, script_to_pose_top1 = 0;
  int64_t groups = 0, group = 0;
};
RetrievalResult pose_text_retrieval(const PoseTextEncoders& m, const text::Tokenizer& tok, const PostureScriptSet& set,
                                    const PoseStats& stats, int64_t group = 32);

}  // namespace t2m::promotion
