// retrieval_train.h — contrastive training of a text–motion retrieval pair (TMR-style; used by `t2m train text`
// for the generator-side encoder and by `t2m train evaluator` for the metric evaluator), and its retrieval scores.
//
// Each step: one loader batch (models/data/loader.h: random windows of cfg.window frames of the train clips,
// left/right mirroring with cfg.mirror_prob, any caption paraphrase of the clip's labels), captions tokenised,
// e_m = embed_motion, e_t = embed_text, loss = symmetric InfoNCE (nn/loss_contrastive.h info_nce: cosine logits
// times the learnable logit scale γ = exp(α), α initialised to ln(1/0.07)). Captions of the same labels (content
// with left/right swapped for mirrored items, style) are the same text id, so they are not negatives of each other
// (TMR's false-negative filtering by label equality). AdamW (no decay on 1-D parameters), linear warm-up + cosine
// decay to lr/10, gradient clipping at norm 1, clamp of α after each step.
// Resumable: nn::TrainState at paths.state every cfg.save_every steps and at the end (model, α, AdamW, step, epoch,
// batch cursor; config equality is checked on resume). Log: paths.log (JSONL: step, loss, lr, logit_scale, grad_norm;
// every cfg.eval_every steps val_top1/2/3) and paths.svg (loss curve). Progress bar on stderr.
// Deterministic for a seed and thread count (loader draws and the model init come from cfg.seed).
//
// retrieval_r_precision: caption i = make_caption(content, style, caption_seed, 0) of clip i (clip.caption when
// set), both embedded with embed_texts / embed_motions (centred crops), then models/eval/metrics.h r_precision in
// batches of 32 over `runs` seeded runs (mean and 95% CI) plus the caption-shuffled control.
// Errors (t2m::Error "train_retrieval: ..."): no model, stats of the wrong dimension, fewer train clips than one
// batch, bad config values (steps < 1, batch < 2, window < 1 or > the model's max_frames, lr <= 0), plus those of
// the loader, train state and log.
#pragma once
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/data/loader.h"
#include "models/eval/metrics.h"
#include "models/text/retrieval_model.h"

namespace t2m::text {

struct RetrievalTrainConfig {
  int64_t steps = 1500;
  int batch = 64;
  double lr = 3e-4;
  double weight_decay = 1e-2;
  int64_t warmup = 100;
  double mirror_prob = 0.5;
  uint64_t seed = 0;
  int64_t save_every = 100;
  int64_t eval_every = 250;  // 0: never (val scores only at the end)
  int64_t stop_at = 0;       // > 0: save and return once this many steps are done (a chunk; not in to_json, so a
                             // later --resume with another stop_at continues the same run)
  nlohmann::json to_json() const;
};

struct RetrievalTrainPaths {
  std::string state, log, svg;
};

struct RetrievalScores {
  std::vector<eval::MeanCI> top;      // R-precision top-1..3
  std::vector<eval::MeanCI> control;  // caption-shuffled control top-1..3
  int64_t clips = 0;
  nlohmann::json to_json() const;
};

struct RetrievalTrainResult {
  int64_t steps = 0;
  double final_loss = 0;  // smoothed loss of the last steps of this run (NaN when no step ran)
  double seconds = 0;
};

// bundle.window is the training window (frames); bundle.model/tokenizer/stats must be set.
RetrievalTrainResult train_retrieval(RetrievalBundle& bundle, const std::vector<data::MotionClip>& train,
                                     const std::vector<data::MotionClip>& val, const RetrievalTrainConfig& cfg,
                                     const RetrievalTrainPaths& paths, bool resume, const std::string& label);

RetrievalScores retrieval_r_precision(const RetrievalBundle& bundle, const std::vector<data::MotionClip>& clips,
                                      uint64_t caption_seed, int runs = 20, uint64_t seed = 0);

}  // namespace t2m::text
