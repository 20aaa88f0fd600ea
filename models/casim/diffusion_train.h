// diffusion_train.h — training the CASIM-MDM denoiser (`t2m train casim --variant diff-*`): the simple x0 loss of
// MDM (Tevet et al. 2023 Eq 2: E ||x0 - G(x_t, t, c)||^2, mean over real frames and feature channels), on windows
// of the train split's normalised features, with condition dropout for classifier-free guidance.
//
// One step: batch from data::MotionLoader (window W frames, shorter clips padded with mask 0, mirroring 0.5,
// captions make_caption(labels, seed, k), k < paraphrases (8)); the captions through the frozen text encoder (no
// graph; encode_diffusion_text); t ~ U{0 .. T-1} and eps ~ N(0, I) from rng "diffusion"; x_t = q_sample (Eq 3);
// drop ~ Bernoulli(cond_dropout) from rng "drop"; loss = mse_loss(G(x_t, t, text, drop, mask), x0, mask).
// AdamW (no decay on 1-D parameters), warm-up + cosine learning rate to lr / 10, gradient clipping at 1.
// Resumable: nn::TrainState at paths.state every save_every steps and at the end (parameters, AdamW moments, the
// two generators, step, epoch, cursor of the loader); resume = bit-identical continuation for the same thread
// count. stop_at > 0 ends the run (resumably) after that many steps in total. JSONL log (step, loss, lr,
// grad_norm) and an SVG plot.
// Errors (t2m::Error "casim train: ..."): bad config values, fewer train clips than a batch, stats of the wrong
// size; TrainState::load errors on a mismatched state.
#pragma once
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/casim/diffusion_denoiser.h"
#include "models/data/loader.h"
#include "models/text/retrieval_model.h"
#include "nn/train_config.h"

namespace t2m::casim {

struct DiffusionTrainConfig : nn::TrainLoopConfig {
  int64_t window = 128;  // frames (4.3 s at 30 fps)
  double mirror_prob = 0.5;
  int paraphrases = 8;
  DiffusionTrainConfig() { steps = 1500, batch = 32, lr = 3e-4, weight_decay = 0.0, warmup = 100, save_every = 100; }
  nlohmann::json to_json() const;
  void validate() const;
};

using DiffusionTrainPaths = nn::TrainPaths;

struct DiffusionTrainResult {
  int64_t steps = 0;       // total steps done
  double final_loss = 0;   // smoothed
  double seconds = 0;      // wall time of this run
  double cpu_seconds = 0;  // process CPU time of this run
};

DiffusionTrainResult train_diffusion(CasimDenoiser& model, const text::RetrievalBundle& text_bundle,
                                     const std::vector<data::MotionClip>& train, const data::FeatureStats& stats,
                                     const DiffusionTrainConfig& cfg, const DiffusionTrainPaths& paths, bool resume,
                                     const std::string& label = "train casim");

}  // namespace t2m::casim
