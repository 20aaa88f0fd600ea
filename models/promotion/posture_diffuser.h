// posture_diffuser.h — PRO-Motion's posture-diffuser (paper Sec 3.3, Fig 4a, appendix D): a DDPM over one
// normalised pose (pose.h, kPoseDim = 187) that predicts x_0 (paper Eq 2) conditioned by cross-attention on the
// token features of a posture script.
//
// Network (x_t (B, 187), step t (B), script tokens ids/mask (B, L)):
//   ctx  = ScriptEncoder(ids, mask).tokens                       (B, L, Dt)  trainable, see below
//   temb = TimestepMLP(sinusoid(t))                              (B, W)      (text2bfm/timestep_embedding.h, t / T)
//   h    = in_proj(x_t)                                          (B, W)
//   N layers:  h += fc2(SiLU(fc1(SiLU(LN(h))) + t_proj(SiLU(temb))))          residual block with the time
//              h += out(attention(q(LN(h)) (B, H, 1, d), k(ctx), v(ctx)))    cross-attention, pose = query
//              h += mlp2(GELU(mlp1(LN(h))))                                  feed-forward (x2)
//   x0_hat = out_proj(LN(h))                                     (B, 187)
// Classifier-free guidance (paper Eq 3): a dropped condition is one learned null token (Dt) as the whole
// context; f_w = f(x, t, null) + w (f(x, t, c) - f(x, t, null)).
// Script encoder: the PRO-Motion paper uses a frozen DistilBERT. Our frozen text encoder (models/text) knows only
// the 299 words of our motion captions ("elbow", "knee", "bent", "ground" ... are <unk>), so the scripts' token
// features come from a small text::TextEncoder (the same class: word embeddings, learned positions, pre-LN
// transformer) over the closed script vocabulary (posture_script_corpus), trained jointly with the diffuser.
// Sizes: the paper's N = 3 layers and width 512; we keep N = 3 and use width 128 (CPU budget, <= 5 MB file).
// Schedule: linear betas 0.00085..0.012 over T = 1000 steps (paper appendix D; diffusion_schedule.h).
// K/V of the context are computed once per script batch (ScriptContext), so sampling costs one small MLP-sized
// forward per step.
// Errors (t2m::Error "PostureDiffuser: ..."): bad config, wrong input shapes.
#pragma once
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "autograd/variable.h"
#include "models/promotion/pose.h"
#include "models/text/text_encoder.h"
#include "models/text/tokenizer.h"
#include "models/text2bfm/timestep_embedding.h"
#include "nn/linear.h"
#include "nn/module.h"
#include "nn/norm.h"

namespace t2m::promotion {

struct PostureDiffuserConfig {
  int64_t width = 128;        // W (paper 512)
  int64_t layers = 3;         // N (paper 3)
  int64_t heads = 4;
  int64_t text_dim = 128;     // Dt, script token features
  int64_t text_layers = 1;
  int64_t max_tokens = 96;    // script tokens incl. <bos>/<eos>; longer scripts are truncated
  int64_t vocab = 0;          // script tokenizer size (set from the tokenizer)
  int64_t diffusion_steps = 1000;
  double beta_start = 0.00085, beta_end = 0.012;
  double cond_drop = 0.1;     // paper: c = null for 10% of the samples
  nlohmann::json to_json() const;
  static PostureDiffuserConfig from_json(const nlohmann::json& j);
  void validate() const;
};

// The script tokenizer: text::Tokenizer::build over posture_script_corpus() (closed vocabulary).
text::Tokenizer script_tokenizer();

// Per-layer K and V of a script batch (or of the null context), reused over the sampling steps.
struct ScriptContext {
  std::vector<ag::Variable> k, v;  // per layer, (B, H, L, d)
  Tensor mask;                     // (B, L) float, 1 = real token; undefined for the null context
};

class PostureDiffuser : public nn::Module {
 public:
  PostureDiffuser(const PostureDiffuserConfig& cfg, Generator& gen);
  const PostureDiffuserConfig& config() const { return cfg_; }

  // Token features of scripts: ids (B, L) int64, mask (B, L) -> context for every layer.
  ScriptContext encode(const Tensor& ids, const Tensor& mask) const;
  // The null context of B rows (every key = the learned null token).
  ScriptContext null_context(int64_t B) const;
  // Context with the rows where drop (B) != 0 replaced by the null token (training-time condition dropout).
  ScriptContext encode_with_drop(const Tensor& ids, const Tensor& mask, const Tensor& drop) const;
  // x0_hat (B, kPoseDim) from x_t (B, kPoseDim) at integer steps t (B) int64.
  ag::Variable forward(const ag::Variable& x_t, const Tensor& t, const ScriptContext& ctx) const;

 private:
  struct Layer {
    std::shared_ptr<nn::LayerNorm> ln1, ln2, ln3;
    std::shared_ptr<nn::Linear> fc1, fc2, t_proj, q, k, v, o, mlp1, mlp2;
  };
  ScriptContext context_from_tokens(const ag::Variable& tokens, const Tensor& mask) const;
  PostureDiffuserConfig cfg_;
  std::shared_ptr<text::TextEncoder> script_;
  std::shared_ptr<text2bfm::TimestepMLP> t_mlp_;
  std::shared_ptr<nn::Linear> in_, out_;
  std::shared_ptr<nn::LayerNorm> out_norm_;
  std::vector<Layer> layers_;
  ag::Variable null_tok_;
};

}  // namespace t2m::promotion
