// ar_train.h — training the token GPT (`t2m train casim --variant ar-cls | ar-tok`) on a cached CodeSet, and its
// teacher-forced evaluation.
//
// Batch (make_ar_batch): B items drawn uniformly (with replacement) from the code set with rng "data"; an item
// longer than max_motion tokens is cropped at a uniform start in [0, len − max_motion]; its caption is
// make_caption(content, style, seed 0, index k, mirrored) with k uniform in [0, 2^31) (any paraphrase).
// Inputs: the crop c_0..c_{n−1}, each replaced with probability `corrupt` by a uniform random code (rng
// "corrupt"; T2M-GPT's teacher-forcing corruption, the τ of the CASIM paper's Table 3); zero-padded to the
// longest crop of the batch. Targets (B, n_max + 1): c_0..c_{n−1}, then the end token K when the crop reaches the
// clip's end (else ignored), −100 (ignored) in the padding.
// Loss: mean cross-entropy over the non-ignored targets (nn::cross_entropy) of ArGpt::forward (CASIM Eq 2).
// Optimiser and schedule as the other trainers: AdamW (decay 0.01, none on 1-D), warm-up + cosine, clip at 1.
// Resumable: nn::TrainState (parameters, AdamW moments, rngs "data" and "corrupt", step); stop_at ends a chunk.
// JSONL log (step, loss, acc, lr, grad_norm), SVG plot, progress bar.
//
// ar_evaluate: teacher-forced mean cross-entropy (nats per token, end token included) and top-1 accuracy on every
// item of a code set (non-mirrored items only), captions make_caption(labels, caption_seed, 0), first max_motion
// tokens, no corruption, batches of 32: deterministic.
// Errors (t2m::Error "ar train: ..."): bad config; empty code set; a code set whose K differs from the model's.
#pragma once
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "models/casim/ar_codes.h"
#include "models/casim/ar_gpt.h"
#include "models/casim/ar_text.h"
#include "models/casim/vq_train.h"
#include "nn/train_config.h"

namespace t2m::casim {

struct ArTrainConfig : nn::TrainLoopConfig {
  double corrupt = 0.2;
  ArTrainConfig() { steps = 1500, batch = 32, lr = 3e-4, warmup = 100, save_every = 100; }
  nlohmann::json to_json() const;
  void validate() const;
};

struct ArBatch {
  ArText text;
  Tensor inputs;   // (B, n_max) int64
  Tensor targets;  // (B, n_max + 1) int64, -100 = ignored
};

// One training batch as described above (rng "data" = data, rng "corrupt" = corrupt).
ArBatch make_ar_batch(const CodeSet& set, const ArTextEncoder& text, int64_t batch, int64_t max_motion,
                      double corrupt, Generator& data, Generator& corrupt_rng);

TrainResult train_ar(ArGpt& model, const CodeSet& set, const ArTextEncoder& text, const ArTrainConfig& cfg,
                     const TrainPaths& paths, bool resume);

struct ArEval {
  double ce = 0, acc = 0;
  int64_t items = 0, targets = 0;
  nlohmann::json to_json() const { return {{"ce_nats", ce}, {"top1_acc", acc}, {"items", items}, {"targets", targets}}; }
};

ArEval ar_evaluate(const ArGpt& model, const CodeSet& set, const ArTextEncoder& text, uint64_t caption_seed);

}  // namespace t2m::casim
