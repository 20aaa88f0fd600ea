// text_encoder.h — the text side of the text–motion retrieval pair (ARCHITECTURE.md section 6): a small pre-LN
// transformer over tokenizer ids that gives per-token features (the y_{j,k} of Text2BFM Eq 7) and one pooled
// sentence feature. Trained contrastively against models/text/motion_encoder.h (TMR-style), then frozen.
//
//   h_0 = tok_emb(ids) + pos_emb[0:L]                      ids (B, L) int64, tok_emb (V, D), pos_emb (max_len, D)
//   h_l = TransformerBlock_l(h_{l-1}, key_mask = mask)     l = 1..layers (nn/transformer_block.h, pre-LN)
//   tokens = LayerNorm(h_layers)                          (B, L, D)  — y_{j,k}; rows where mask = 0 are meaningless
//   pooled = proj( sum_k mask_k tokens_k / sum_k mask_k )  (B, E)     — masked mean, then Linear(D, E)
// mask (B, L) float32, 1 = real token (<bos>, words, <eos>), as Tokenizer::encode_batch gives it. Padded
// positions never influence real positions (key padding mask) nor the pooled feature (masked mean), so the
// outputs at real tokens do not depend on the padding length or the ids written into padding.
// Parameters (in order; a Module lists its own before its children's): pos_emb, tok_emb.weight, block<l>.*,
// norm.{weight,bias}, proj.{weight,bias}.
// Init: tok_emb and pos_emb N(0, 0.02^2) (tok_emb drawn N(0, 1) by nn::Embedding, then scaled); the rest as their
// modules (PyTorch defaults) — all from the Generator.
// Works in float32 and (after to(f64)) float64.
// Errors (t2m::Error, message starts "TextEncoder:"): config sizes < 1, dim not divisible by heads (at
// construction); ids not (B, L) int64, L > max_len or L < 1, mask not (B, L) float, a row with no real token.
#pragma once
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <vector>

#include "autograd/variable.h"
#include "nn/embedding.h"
#include "nn/linear.h"
#include "nn/module.h"
#include "nn/norm.h"
#include "nn/transformer_block.h"
#include "tensor/rng.h"

namespace t2m::text {

struct TextEncoderConfig {
  int64_t vocab = 0;  // tokenizer vocab_size()
  int64_t dim = 256;  // D: token feature width (y_{j,k})
  int64_t layers = 2;
  int64_t heads = 4;
  int64_t mlp_ratio = 4;
  int64_t max_len = 32;     // longest token sequence (positions)
  int64_t embed_dim = 256;  // E: pooled sentence feature width

  nlohmann::json to_json() const;
  static TextEncoderConfig from_json(const nlohmann::json& j);  // throws t2m::Error on missing/bad fields
  void validate() const;
};

struct TextFeatures {
  ag::Variable tokens;  // (B, L, D)  per-token features y_{j,k}
  ag::Variable pooled;  // (B, E)     sentence feature (not normalised)
};

// Masked mean over dim 1: x (B, L, C), mask (B, L) float (1 = keep) -> (B, C). Every row needs a real entry.
ag::Variable masked_mean(const ag::Variable& x, const Tensor& mask, const char* who);

class TextEncoder : public nn::Module {
 public:
  TextEncoder(const TextEncoderConfig& cfg, Generator& gen);
  TextFeatures forward(const Tensor& ids, const Tensor& mask) const;
  const TextEncoderConfig& config() const { return cfg_; }

 private:
  TextEncoderConfig cfg_;
  ag::Variable pos_;
  std::shared_ptr<nn::Embedding> tok_;
  std::vector<std::shared_ptr<nn::TransformerBlock>> blocks_;
  std::shared_ptr<nn::LayerNorm> norm_;
  std::shared_ptr<nn::Linear> proj_;
};

}  // namespace t2m::text
