// go_diffuser_train.h — training the go-diffuser (`t2m train promotion --variant go`): windows of T frames of the
// train split (data::MotionLoader: random start, mirror augmentation 0.5, normalised with the train stats), the K
// key poses of each window taken from its own ground-truth frames by pose.h's rule over the window's real length,
// x_0-form DDPM loss (go_diffuser_loss) at uniform steps t, per-sample key-token dropout cond_drop (CFG), AdamW
// (no decay on 1-D parameters), warm-up + cosine learning rate, gradient clipping at 1, in resumable chunks.
//
// Randomness: rng "noise" (t and eps), rng "drop" (key dropout); batches from the loader keyed by (seed, epoch)
// with the TrainState's epoch and cursor (batches done in the epoch), so a resumed run continues bit-identically
// for the same thread count. State at paths.state every save_every steps and at the end; JSONL log (step, loss,
// lr, grad_norm) and an SVG plot. stop_at > 0 ends the run (resumably) after that many steps in total.
// Errors (t2m::Error, "go train: ..."): bad config, no clips; and TrainState::load's on a mismatched state.
#pragma once
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/data/loader.h"
#include "models/promotion/go_diffuser.h"
#include "nn/train_config.h"

namespace t2m::promotion {

struct GoTrainConfig : nn::TrainLoopConfig {
  GoTrainConfig() { steps = 1400, batch = 16, lr = 3e-4, warmup = 50, save_every = 100; }
  nlohmann::json to_json() const { return common_json(); }
  void validate() const { validate_common("go train", to_json()); }
};

using GoTrainPaths = nn::TrainPaths;

using GoTrainResult = nn::TrainRunResult;

// The key poses (B, K, 187) and key frames (B, K) of a normalised batch x (B, T, 257) with real lengths.
void batch_key_poses(const Tensor& x, const std::vector<int>& lengths, int64_t K, Tensor* keys, Tensor* key_frames);

GoTrainResult train_go_diffuser(GoDiffuser& m, const std::vector<data::MotionClip>& clips,
                                const data::FeatureStats& stats, const GoTrainConfig& cfg, const GoTrainPaths& paths,
                                bool resume, const std::string& label = "train promotion go");

}  // namespace t2m::promotion
