// vq_train.h — training and evaluating the motion tokenizer (`t2m train casim --variant vq`).
//
// One step: a batch of B windows of W frames (data::MotionLoader over the train clips: random window, mirror
// augmentation p = 0.5, normalised with the train-split stats, zero-padded with a frame mask), vq_loss
// (vq_vae.h), AdamW (no decay on 1-D parameters) on the conv weights with warm-up + cosine learning rate and
// gradient clipping at 1, then VqCodebook::ema_update on the batch's real encoder outputs (the first step sets
// the codes from encoder outputs; later steps do the EMA and reset dead codes from rng "reset").
// Resumable: nn::TrainState at paths.state every save_every steps and at the end (parameters including the
// codebook and its EMA state, AdamW moments, the reset generator, step, loader epoch + cursor); resuming gives the
// same steps as an uninterrupted run for the same thread count. stop_at > 0 ends the run after that many steps in
// total. JSONL log (step, loss, rec, vel, commit, resets, lr, grad_norm), SVG plot, progress bar.
//
// vq_evaluate: every clip (frames trimmed to a multiple of 4; whole clip, one at a time) is tokenized and decoded;
//   rec_mse      mean squared error of the normalised features over all frames and dims,
//   mpjpe_m      root-relative mean per-joint position error (metres): features_to_positions of the raw
//                reconstruction vs of the raw input, each joint minus its frame's root (so root drift is excluded),
//   used         codes used at least once, perplexity = exp(entropy) of the code histogram, tokens = count.
// Errors (t2m::Error "vq train: ..."): bad config values; empty clip list; TrainState errors on a mismatched state.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "models/casim/vq_vae.h"
#include "models/data/features_norm.h"
#include "models/data/loader.h"
#include "nn/train_config.h"

namespace t2m::casim {

struct VqTrainConfig : nn::TrainLoopConfig {
  int64_t window = 64;
  VqTrainConfig() { steps = 2000, batch = 32, lr = 5e-4, weight_decay = 0.0, warmup = 100, save_every = 200; }
  nlohmann::json to_json() const;
  void validate() const;
};

using TrainPaths = nn::TrainPaths;

struct TrainResult {
  int64_t steps = 0;
  double final_loss = 0;   // smoothed
  double seconds = 0;      // wall time of this call
  double cpu_seconds = 0;  // process CPU time of this call
};

TrainResult train_vq(VqVae& model, const std::vector<data::MotionClip>& train, const data::FeatureStats& stats,
                     const VqTrainConfig& cfg, const TrainPaths& paths, bool resume);

struct VqEval {
  double rec_mse = 0, mpjpe_m = 0, perplexity = 0;
  int64_t used = 0, codes = 0, tokens = 0, clips = 0;
  nlohmann::json to_json() const;
};

VqEval vq_evaluate(const VqVae& model, const std::vector<data::MotionClip>& clips, const data::FeatureStats& stats);

// Process CPU seconds (user + system) so far.
double process_cpu_seconds();

}  // namespace t2m::casim
