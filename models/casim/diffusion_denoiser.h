// diffusion_denoiser.h — the MDM-style motion denoiser of the CASIM diffusion baseline: predicts the clean motion
// x0 from a noisy one x_t (x0-parametrisation, MDM; CASIM Eq 3), conditioned on text in one of three ways:
//
//   h    = in_proj(x_t) + PE(0 .. T-1)                 (B, T, W)   motion tokens, fixed sinusoidal positions
//   temb = t_mlp(timestep_embedding(t / steps))        (B, W)      diffusion-step embedding (1000 t / T scale)
//   cls  (sentence-level, MDM): c = temb + cls_proj(pooled) (or the learned null vector when dropped);
//        encoder over [c ; h] (TransformerBlock x layers, key mask [1 ; frame_mask]); the motion part is read out.
//   mhsa (CASIM encoder, Eq 4): y = tok_proj(tokens) (or the null token when dropped) + temb per token;
//        encoder over [y ; h] with mask [tok_mask ; frame_mask] (aligner.h join_text_motion).
//   mhca (CASIM decoder, Eq 5): y as mhsa; CrossAlignerBlock x layers over h with cross-attention to y.
//   x0_hat = out_proj(out_norm(h))                     (B, T, F)
//
// Inputs: x_t (B, T, F) normalised features (models/data/features_norm.h; F = 257), t (B) int64 diffusion step in
// [0, steps), DiffusionText {tokens (B, L, text_dim) frozen token features, tok_mask (B, L), pooled (B, pooled_dim)
// the frozen sentence embedding}, drop (B) or undefined (1 = use the null condition: classifier-free guidance),
// frame_mask (B, T) or undefined (padded frames are never attended to; their outputs are meaningless).
// Parameters (in order): null (W), t_mlp.{0,2}.*, in_proj.*, cls_proj.* (cls) | tok_proj.* (mhsa, mhca),
// block<N>.*, out_norm.*, out_proj.*. PyTorch default init; null ~ N(0, 0.02^2). All from the Generator.
// Errors (t2m::Error "CasimDenoiser: ..."): bad config (sizes < 1, width not divisible by heads, unknown
// conditioning name), input shapes (naming them), t out of range.
#pragma once
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "autograd/variable.h"
#include "models/casim/aligner.h"
#include "models/text2bfm/timestep_embedding.h"
#include "nn/linear.h"
#include "nn/module.h"
#include "nn/norm.h"
#include "nn/transformer_block.h"
#include "tensor/rng.h"

namespace t2m::casim {

enum class Conditioning : uint8_t { cls, mhsa, mhca };
const char* conditioning_name(Conditioning c);           // "cls", "mhsa", "mhca"
Conditioning conditioning_from_name(const std::string& s);  // throws on other names

struct DenoiserConfig {
  Conditioning cond = Conditioning::mhsa;
  int64_t feature_dim = 257;
  int64_t width = 128;
  int64_t layers = 4;
  int64_t heads = 4;
  int64_t mlp_ratio = 4;
  int64_t freq_dim = 128;     // sinusoidal timestep features
  int64_t text_dim = 256;     // token features of the frozen text encoder
  int64_t pooled_dim = 256;   // its pooled sentence feature
  int64_t diffusion_steps = 1000;
  double cond_dropout = 0.1;  // training: P(null condition)

  nlohmann::json to_json() const;
  static DenoiserConfig from_json(const nlohmann::json& j);  // missing keys keep defaults; unknown keys throw
  void validate() const;
};

struct DiffusionText {
  Tensor tokens;    // (B, L, text_dim)
  Tensor tok_mask;  // (B, L) float 0/1
  Tensor pooled;    // (B, pooled_dim)
};

// MDM's fixed sinusoidal positional encoding (Vaswani et al.): (T, W), PE[p, 2i] = sin(p / 10000^(2i/W)),
// PE[p, 2i+1] = cos(...). W even.
Tensor sinusoidal_positions(int64_t T, int64_t W, DType dtype = DType::f32);

class CasimDenoiser : public nn::Module {
 public:
  CasimDenoiser(const DenoiserConfig& cfg, Generator& gen);
  // x0_hat: see above.
  ag::Variable forward(const ag::Variable& x_t, const Tensor& t, const DiffusionText& text,
                       const Tensor& drop = Tensor(), const Tensor& frame_mask = Tensor()) const;
  // (B) 0/1 draws, 1 with probability cond_dropout.
  Tensor sample_condition_drop(int64_t B, Generator& gen) const;
  const DenoiserConfig& config() const { return cfg_; }

 private:
  ag::Variable time_embedding(const Tensor& t, DType dtype) const;  // (B, W)
  DenoiserConfig cfg_;
  ag::Variable null_;
  std::shared_ptr<text2bfm::TimestepMLP> t_mlp_;
  std::shared_ptr<nn::Linear> in_proj_, cond_proj_, out_proj_;
  std::vector<std::shared_ptr<nn::TransformerBlock>> enc_;
  std::vector<std::shared_ptr<CrossAlignerBlock>> dec_;
  std::shared_ptr<nn::LayerNorm> out_norm_;
};

}  // namespace t2m::casim
