// motion_encoder.h — the motion side of the text–motion retrieval pair (TMR-style, ARCHITECTURE.md section 6):
// a pre-LN transformer over patches of normalised motion features with a padding mask -> one pooled embedding.
//
//   x (B, T, F) normalised features (models/data/features_norm.h), mask (B, T) float, 1 = real frame; right
//   padding (real frames first), as the loader gives it. T is zero-padded up to a multiple of `patch`.
//   patches   p (B, P, patch*F), P = ceil(T / patch); patch mask = 1 where the patch holds a real frame
//   h_0 = in_proj(p) + pos_emb[0:P]                    in_proj Linear(patch*F, D), pos_emb (max_patches, D)
//   h_l = TransformerBlock_l(h_{l-1}, key_mask)        l = 1..layers
//   tokens = LayerNorm(h_layers)                       (B, P, D)
//   pooled = proj(masked_mean(tokens, patch mask))     (B, E)
// Padded frames are zero inside the input projection's window only when the caller zeroes them (the loader
// does); the encoder multiplies x by the frame mask first, so values written into padding never matter.
// Parameters (in order; own before children's): pos_emb, in_proj.{weight,bias}, block<l>.*, norm.{weight,bias},
// proj.{weight,bias}.
// Errors (t2m::Error, "MotionEncoder: ..."): bad config at construction; x not (B, T, F) float with F = config,
// T < 1, more than max_patches patches, mask not (B, T) float, a sequence with no real frame.
#pragma once
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <vector>

#include "autograd/variable.h"
#include "nn/linear.h"
#include "nn/module.h"
#include "nn/norm.h"
#include "nn/transformer_block.h"
#include "tensor/rng.h"

namespace t2m::text {

struct MotionEncoderConfig {
  int64_t feature_dim = 257;  // F (models/data/features.h kFeatureDim)
  int64_t patch = 8;          // frames per token (0.27 s at 30 fps)
  int64_t dim = 256;
  int64_t layers = 2;
  int64_t heads = 4;
  int64_t mlp_ratio = 4;
  int64_t max_patches = 64;  // longest input: max_patches * patch frames
  int64_t embed_dim = 256;

  nlohmann::json to_json() const;
  static MotionEncoderConfig from_json(const nlohmann::json& j);  // throws t2m::Error on missing/bad fields
  void validate() const;
};

// Frames -> patches: x (B, T, F) -> (B, ceil(T/patch), patch*F) with x * mask, zero-padded; patch mask (B, P) = 1
// where any frame of the patch is real. Shared by the motion encoders (also models/eval/evaluator.h).
struct Patches {
  ag::Variable x;  // (B, P, patch*F)
  Tensor mask;     // (B, P) of x's dtype
};
Patches patchify(const ag::Variable& x, const Tensor& mask, int64_t patch, int64_t feature_dim, const char* who);

class MotionEncoder : public nn::Module {
 public:
  MotionEncoder(const MotionEncoderConfig& cfg, Generator& gen);
  // x (B, T, F), mask (B, T) -> pooled (B, E) (not normalised).
  ag::Variable forward(const ag::Variable& x, const Tensor& mask) const;
  const MotionEncoderConfig& config() const { return cfg_; }

 private:
  MotionEncoderConfig cfg_;
  std::shared_ptr<nn::Linear> in_proj_;
  ag::Variable pos_;
  std::vector<std::shared_ptr<nn::TransformerBlock>> blocks_;
  std::shared_ptr<nn::LayerNorm> norm_;
  std::shared_ptr<nn::Linear> proj_;
};

}  // namespace t2m::text
