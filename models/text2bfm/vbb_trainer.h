// vbb_trainer.h — the training loop of the VBB (Text2BFM Eq 13) on cached policy latents (latent_cache.h):
// random windows of the train split's clips, the frozen BFM actor for Eq 5, the frozen text encoder's token
// features for Eq 7–12, AdamW, and an nn::TrainState that resumes bit-identically.
//
// One step (VbbTrainer::step):
//   batch: for each of `batch` rows, from the "data" generator: a clip c (uniform), a start t0 (uniform in
//     [0, max(0, Tz_c − window)]), a caption index k (uniform in [0, paraphrases)); rows z[t0 .. t0 + len) and the
//     paired states, len = min(window, Tz_c); shorter clips are right-padded by repeating the last real frame
//     with frame mask 0 (they add nothing to any loss: masks in Eq 5/6, program_mask_from_frames in Eq 6–12).
//     caption = data::make_caption(content_c, style_c, caption_seed, k) -> text(captions) -> tokens (B, K, D)
//     and mask (B, K). Rows with the same (content, style) labels share a caption id (false negatives are not
//     counted as negatives in Eq 10–11).
//   forward: Vbb::forward in train mode (dropout and eps from the "model" generator), vbb_loss (Eq 13) with the
//     frozen actor (may be empty: no KL term) and the semantic head (absent when lambda_sem = 0 or no text).
//   update: grad-norm clip (grad_clip, 0 = off), AdamW (lr from a warm-up + cosine schedule to lr/10 when
//     cosine, else constant after warm-up; weight decay on >= 2-D parameters), then nn::clamp_logit_scale_.
// Determinism: the generators "data" and "model" and the step count live in the TrainState, so a run stopped at
// any step and resumed gives the same parameters bit for bit as a straight run (same thread count).
// The trained modules: "vbb." (Vbb) and "head." (VbbSemanticHead, only when used); TrainState config = to_json().
// Errors (t2m::Error "vbb train: ..."): bad config values (named), a latent set without clips or of another z_dim,
// states of another obs_dim than the actor's, a text function returning the wrong shapes.
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/bfm/fb_agent.h"
#include "models/text2bfm/latent_cache.h"
#include "models/text2bfm/vbb.h"
#include "models/text2bfm/vbb_loss.h"
#include "models/text2bfm/vbb_semantic_head.h"
#include "nn/optim_adamw.h"
#include "nn/train_state.h"

namespace t2m::text2bfm {

struct VbbTrainConfig {
  VbbConfig vbb;
  VbbLossOptions loss;
  int64_t batch = 32;
  int64_t window = 64;        // Tz per training window (a multiple of the compression)
  int64_t steps = 2000;
  int64_t warmup = 100;
  bool cosine = true;
  double lr = 5e-5;           // paper
  double weight_decay = 5e-4; // paper
  double grad_clip = 1.0;
  int64_t sem_dim = 128;      // D of the semantic head's shared space
  uint64_t seed = 0;
  uint64_t caption_seed = 0;
  int paraphrases = 16;       // caption indices drawn per clip
  bool pool_init = false;     // start at average pooling (vbb_average_pool.h; needs latent == in_dim); ours, not
                              // the paper's: docs/VBB.md "Why the VBB lost to pooling"

  nlohmann::json to_json() const;
  static VbbTrainConfig from_json(const nlohmann::json& j);  // missing keys keep defaults
  void validate() const;
};

// Token features of a caption batch: tokens (B, K, D) float32, mask (B, K) float32.
struct TokenFeatures {
  Tensor tokens, mask;
};
using TextFeatureFn = std::function<TokenFeatures(const std::vector<std::string>& captions)>;

// The BFM actor as Eq 5's frozen π: mean = actor(s, z) per frame, log std = log(actor_std) (fixed). Marks the
// actor's parameters requires_grad = false. The agent must outlive the returned callable.
FrozenActor frozen_bfm_actor(bfm::FbAgent& agent);

struct VbbStepStats {
  double total = 0, latent_mse = 0, action_kl = 0, kl = 0, sem = 0, grad_norm = 0, lr = 0;
};

class VbbTrainer {
 public:
  // agent: may be null (no Eq 5 KL term). text: may be empty (no L_sem); text_dim = its token width.
  VbbTrainer(const VbbTrainConfig& cfg, const LatentSet& train, bfm::FbAgent* agent, TextFeatureFn text,
             int64_t text_dim);
  VbbStepStats step();
  int64_t steps_done() const { return ts_->step; }
  void save(const std::string& path) const { ts_->save(path); }
  void load(const std::string& path) { ts_->load(path); }
  const VbbConfig& vbb_config() const { return cfg_.vbb; }
  Vbb& model() { return *vbb_; }
  const VbbSemanticHead* head() const { return head_.get(); }

 private:
  VbbTargets sample_batch(std::vector<std::string>& captions);

  VbbTrainConfig cfg_;
  const LatentSet& data_;
  FrozenActor actor_;
  TextFeatureFn text_;
  Generator init_gen_, data_gen_, model_gen_;
  std::shared_ptr<Vbb> vbb_;
  std::shared_ptr<VbbSemanticHead> head_;
  nn::NamedParams params_;
  std::unique_ptr<nn::AdamW> opt_;
  std::unique_ptr<nn::TrainState> ts_;
};

}  // namespace t2m::text2bfm
