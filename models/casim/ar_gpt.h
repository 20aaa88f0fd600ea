// ar_gpt.h — the GPT-style motion-token generator of the autoregressive CASIM baseline (T2M-GPT, Zhang et al.
// 2023a; CASIM paper Sec. 3.2, Eq 1–2), with two ways to inject the text:
//   cls: the frozen text encoder's pooled sentence feature (B, E) -> Linear -> ONE prefix token (T2M-GPT's CLIP
//        [CLS] condition);
//   tok: CASIM's composite-aware injection: the token features y (B, L, Dt) -> Linear + learned text positions
//        -> L prefix tokens; causal MHSA over [text tokens, motion tokens] is the text–motion aligner (Eq 2).
//
// Sequence (length S = P + 1 + n; P = 1 for cls, L for tok):
//   [ prefix_0 .. prefix_{P-1},  som + pos_0,  tok_emb(c_0) + pos_1, ..., tok_emb(c_{n-1}) + pos_n ]
//   som = a learned start-of-motion vector; pos = learned motion positions (max_motion + 1 rows).
//   Every block is a pre-LN nn::TransformerBlock with ONE causal mask over the whole sequence (so the text prefix
//   attends causally among itself, as a decoder-only GPT does; we do not give the prefix a bidirectional block)
//   plus a key-padding mask: padded text tokens (mask 0) are never attended to, so the outputs at real positions do
//   not depend on the padding.
// Output: logits (B, n + 1, K + 1) at [som, c_0 .. c_{n-1}]: row i predicts c_i, row n predicts c_n or the end token
//   (id K). p(c_i | c_<i, text) = softmax(logits_i)                                                 (CASIM Eq 2)
// Parameters (in order): som, motion_pos, text_pos (tok only), text_proj.*, tok_emb.weight, block<i>.*, norm.*,
// head.*. Init: som, positions N(0, 0.02²), tok_emb N(0, 0.02²), the rest their modules' PyTorch defaults.
// Errors (t2m::Error "ar gpt: ..."): bad config; cond tensors of the wrong shape for the mode; L > max_text;
// n > max_motion; codes not int64 (B, n) or outside [0, K).
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "autograd/variable.h"
#include "nn/embedding.h"
#include "nn/linear.h"
#include "nn/module.h"
#include "nn/norm.h"
#include "nn/transformer_block.h"
#include "tensor/rng.h"

namespace t2m::casim {

enum class ArCond { cls, tok };
const char* ar_cond_name(ArCond c);        // "cls", "tok"
ArCond ar_cond_from_name(const std::string& s);  // throws on other strings

struct ArGptConfig {
  ArCond cond = ArCond::tok;
  int64_t codes = 512;       // K (the tokenizer's codebook); the end token is id K
  int64_t max_motion = 48;   // motion tokens per sequence (48 x 4 = 192 frames = 6.4 s at 30 fps)
  int64_t text_dim = 256;    // Dt, token features (tok)
  int64_t pooled_dim = 256;  // E, sentence feature (cls)
  int64_t max_text = 32;     // L_max (tok)
  int64_t dim = 192;
  int64_t layers = 4;
  int64_t heads = 4;
  int64_t mlp_ratio = 4;

  int64_t end_token() const { return codes; }
  nlohmann::json to_json() const;
  static ArGptConfig from_json(const nlohmann::json& j);
  void validate() const;
};

// The text condition: tokens (B, L, Dt) + mask (B, L) float (1 = real) for tok; pooled (B, E) for cls.
struct ArText {
  Tensor tokens, mask, pooled;
};

class ArGpt : public nn::Module {
 public:
  ArGpt(const ArGptConfig& cfg, Generator& gen);
  // codes (B, n) int64 with 0 <= n <= max_motion -> logits (B, n + 1, K + 1).
  ag::Variable forward(const ArText& text, const Tensor& codes) const;
  const ArGptConfig& config() const { return cfg_; }

 private:
  ag::Variable prefix(const ArText& text, Tensor* key_mask) const;  // (B, P, dim), key mask (B, P)
  ArGptConfig cfg_;
  ag::Variable som_, motion_pos_, text_pos_;
  std::shared_ptr<nn::Linear> text_proj_, head_;
  std::shared_ptr<nn::Embedding> tok_emb_;
  std::vector<std::shared_ptr<nn::TransformerBlock>> blocks_;
  std::shared_ptr<nn::LayerNorm> norm_;
};

}  // namespace t2m::casim
