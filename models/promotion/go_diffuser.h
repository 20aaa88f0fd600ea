// go_diffuser.h — PRO-Motion's go-diffuser (Sec 3.4, Fig 4 b, App. D): a transformer-encoder DDPM that turns K key
// poses (without global translation or heading change) into a whole motion window: per-frame root yaw velocity,
// planar velocity (features [0, 4)) and the body, i.e. the full raw-feature sequence [T, 257], normalised.
//
// Window: T frames (default 64 = 2.1 s at 30 fps, the paper's 64), K key poses (default 8) at the frames of
// pose.h's rule, frame_i = round(i (T - 1) / (K - 1)). Poses are normalised with the pose dims of the feature
// stats (so a key pose equals dims [3, 190) of the normalised features at its frame).
// Network (x_0 prediction, as the paper's "predicted motion sequence x̂_0"):
//   time token   TimestepMLP(sinusoid(t))                                   (B, 1, W)   t = DDPM step 0..S-1
//   key tokens   Linear(187 -> W)(key) + PE(key frame) + type_key            (B, K, W)   one token per key pose
//   frame tokens Linear(257 -> W)(x_t) + PE(frame)                          (B, T, W)
//   h = TransformerBlock x layers([time; keys; frames], key_mask = [1; key_mask; 1])   pre-LN, tanh-GELU MLP
//   x̂_0 = Linear(W -> 257)(LayerNorm(h[frames]))                            (B, T, 257)
// PE(f) = the sinusoid of frame index f (timestep_embedding(f / 1000, W): cos/sin of f·10000^{-i/h}), shared by
// key and frame tokens so attention can match a key pose to its frame. Key poses are separate tokens (the paper:
// "discrete tokens rather than a unified feature"). Classifier-free training: each sample's key tokens are all
// masked out with probability cond_drop (0.1, App. D); guided x̂_0 = x̂_u + w (x̂_c − x̂_u) (w = 1: no guidance).
// Paper config: 8 layers, 4 heads, width 512, dropout 0.1, cosine schedule, 100 steps. CPU default here (see
// docs/PROMOTION.md): width 128, 4 layers, 4 heads, MLP x2, no dropout, cosine schedule, 100 steps.
// Errors (t2m::Error, "go_diffuser: ..."): bad config (sizes < 1, width not divisible by heads or odd, keys > frames);
// inputs of the wrong shape/dtype (named with both shapes), key frames outside [0, T).
#pragma once
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <vector>

#include "autograd/variable.h"
#include "models/promotion/diffusion_schedule.h"
#include "models/text2bfm/timestep_embedding.h"
#include "nn/linear.h"
#include "nn/module.h"
#include "nn/norm.h"
#include "nn/transformer_block.h"
#include "tensor/rng.h"

namespace t2m::promotion {

struct GoDiffuserConfig {
  int64_t frames = 64;        // T
  int64_t keys = 8;           // K
  int64_t width = 128;        // W
  int64_t layers = 4;
  int64_t heads = 4;
  int64_t mlp_ratio = 2;
  int64_t diffusion_steps = 100;
  double cond_drop = 0.1;
  nlohmann::json to_json() const;
  static GoDiffuserConfig from_json(const nlohmann::json& j);
  void validate() const;
};

class GoDiffuser : public nn::Module {
 public:
  GoDiffuser(const GoDiffuserConfig& cfg, Generator& gen);

  // x_t (B, T, 257), t int64 (B), keys (B, K, 187), key_frames int64 (B, K), key_mask float (B, K) (1 = present,
  // 0 = masked: dropped for CFG or absent) -> x̂_0 (B, T, 257).
  ag::Variable forward(const ag::Variable& x_t, const Tensor& t, const ag::Variable& keys, const Tensor& key_frames,
                       const Tensor& key_mask) const;

  // Per-sample CFG drop: float (B) with 1 = keep the key tokens, drawn Bernoulli(1 - cond_drop) from gen.
  Tensor sample_key_keep(int64_t batch, Generator& gen) const;

  // DDPM ancestral sampling (100 steps) of B windows from key poses (B, K, 187) normalised, key_frames (B, K):
  // returns normalised features (B, T, 257). guidance w (1 = conditional only). Noise from gen.
  // inpaint (ours, not in the paper): at every step the x_0 estimate's pose dims [3, 190) at the key frames are
  // replaced by the key poses (replacement inpainting), so the sample passes through its key poses exactly and the
  // network fills in the rest (translation, velocities, in-between frames).
  Tensor sample(const Tensor& keys, const Tensor& key_frames, Generator& gen, double guidance = 1.0,
                bool inpaint = false) const;

  const GoDiffuserConfig& config() const { return cfg_; }
  const DiffusionSchedule& schedule() const { return sched_; }

 private:
  GoDiffuserConfig cfg_;
  DiffusionSchedule sched_;
  std::shared_ptr<text2bfm::TimestepMLP> time_;
  std::shared_ptr<nn::Linear> key_in_, frame_in_, out_;
  ag::Variable key_type_;
  std::vector<std::shared_ptr<nn::TransformerBlock>> blocks_;
  std::shared_ptr<nn::LayerNorm> norm_;
};

// The go-diffuser's training loss: mean over real frames and feature dims of (x̂_0 − x_0)^2 (simple DDPM loss in
// x_0 form). x0 (B, T, 257) normalised, frame_mask (B, T) float; t, keys, key_frames, key_keep as in forward.
// eps ~ N(0, I) is given by the caller (from its noise Generator).
ag::Variable go_diffuser_loss(const GoDiffuser& m, const Tensor& x0, const Tensor& frame_mask, const Tensor& t,
                              const Tensor& eps, const Tensor& keys, const Tensor& key_frames, const Tensor& key_keep);

}  // namespace t2m::promotion
