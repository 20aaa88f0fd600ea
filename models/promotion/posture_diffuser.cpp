// posture_diffuser.cpp — the x0-predicting posture denoiser: residual time block + single-query cross-attention
// over script tokens per layer (see posture_diffuser.h).
#include "models/promotion/posture_diffuser.h"

#include <cmath>
#include <string>

#include "autograd/ops_activation.h"
#include "autograd/ops_attention.h"
#include "autograd/ops_elementwise.h"
#include "autograd/ops_shape.h"
#include "models/promotion/posture_script.h"
#include "tensor/ops.h"
#include "tensor/rng.h"

namespace t2m::promotion {

namespace {

int64_t get_i(const nlohmann::json& j, const char* k) {
  if (!j.contains(k) || !j[k].is_number_integer())
    throw Error(std::string("PostureDiffuser: config field '") + k + "' missing or not an integer in " + j.dump());
  return j[k].get<int64_t>();
}
double get_d(const nlohmann::json& j, const char* k) {
  if (!j.contains(k) || !j[k].is_number())
    throw Error(std::string("PostureDiffuser: config field '") + k + "' missing or not a number in " + j.dump());
  return j[k].get<double>();
}

}  // namespace

nlohmann::json PostureDiffuserConfig::to_json() const {
  return {{"width", width},         {"layers", layers},         {"heads", heads},
          {"text_dim", text_dim},   {"text_layers", text_layers}, {"max_tokens", max_tokens},
          {"vocab", vocab},         {"diffusion_steps", diffusion_steps}, {"beta_start", beta_start},
          {"beta_end", beta_end},   {"cond_drop", cond_drop}};
}

PostureDiffuserConfig PostureDiffuserConfig::from_json(const nlohmann::json& j) {
  PostureDiffuserConfig c;
  c.width = get_i(j, "width");
  c.layers = get_i(j, "layers");
  c.heads = get_i(j, "heads");
  c.text_dim = get_i(j, "text_dim");
  c.text_layers = get_i(j, "text_layers");
  c.max_tokens = get_i(j, "max_tokens");
  c.vocab = get_i(j, "vocab");
  c.diffusion_steps = get_i(j, "diffusion_steps");
  c.beta_start = get_d(j, "beta_start");
  c.beta_end = get_d(j, "beta_end");
  c.cond_drop = get_d(j, "cond_drop");
  c.validate();
  return c;
}

void PostureDiffuserConfig::validate() const {
  if (width < 1 || layers < 1 || heads < 1 || text_dim < 1 || text_layers < 1 || max_tokens < 2 || vocab < 5 ||
      diffusion_steps < 1 || width % heads != 0 || text_dim % heads != 0 || !(beta_start > 0) ||
      !(beta_end >= beta_start) || !(beta_end < 1) || cond_drop < 0 || cond_drop > 1)
    throw Error("PostureDiffuser: bad config " + to_json().dump() +
                " (sizes >= 1, width and text_dim divisible by heads, vocab >= 5, 0 < beta_start <= beta_end < 1)");
}

text::Tokenizer script_tokenizer() { return text::Tokenizer::build(posture_script_corpus()); }

PostureDiffuser::PostureDiffuser(const PostureDiffuserConfig& cfg, Generator& gen) : cfg_(cfg) {
  cfg_.validate();
  text::TextEncoderConfig tc;
  tc.vocab = cfg_.vocab;
  tc.dim = cfg_.text_dim;
  tc.layers = cfg_.text_layers;
  tc.heads = cfg_.heads;
  tc.mlp_ratio = 2;
  tc.max_len = cfg_.max_tokens;
  tc.embed_dim = 1;  // the pooled feature is not used
  const int64_t W = cfg_.width, Dt = cfg_.text_dim;
  script_ = register_module("script", std::make_shared<text::TextEncoder>(tc, gen));
  t_mlp_ = register_module("t_mlp", std::make_shared<text2bfm::TimestepMLP>(128, W, gen));
  in_ = register_module("in_proj", std::make_shared<nn::Linear>(kPoseDim, W, true, gen));
  for (int64_t l = 0; l < cfg_.layers; ++l) {
    const std::string p = "layer" + std::to_string(l) + "_";
    auto lin = [&](const char* n, int64_t i, int64_t o) {
      return register_module(p + n, std::make_shared<nn::Linear>(i, o, true, gen));
    };
    Layer L;
    L.ln1 = register_module(p + "ln1", std::make_shared<nn::LayerNorm>(W));
    L.fc1 = lin("fc1", W, W);
    L.t_proj = lin("t_proj", W, W);
    L.fc2 = lin("fc2", W, W);
    L.ln2 = register_module(p + "ln2", std::make_shared<nn::LayerNorm>(W));
    L.q = lin("q", W, W);
    L.k = lin("k", Dt, W);
    L.v = lin("v", Dt, W);
    L.o = lin("o", W, W);
    L.ln3 = register_module(p + "ln3", std::make_shared<nn::LayerNorm>(W));
    L.mlp1 = lin("mlp1", W, 2 * W);
    L.mlp2 = lin("mlp2", 2 * W, W);
    layers_.push_back(L);
  }
  out_norm_ = register_module("out_norm", std::make_shared<nn::LayerNorm>(W));
  out_ = register_module("out_proj", std::make_shared<nn::Linear>(W, kPoseDim, true, gen));
  null_tok_ = register_parameter("null_tok", rand_normal({Dt}, gen, 0.0, 0.02));
}

// tokens (B, L, Dt) -> per-layer K, V (B, H, L, d)
ScriptContext PostureDiffuser::context_from_tokens(const ag::Variable& tokens, const Tensor& mask) const {
  const int64_t B = tokens.size(0), L = tokens.size(1), H = cfg_.heads, d = cfg_.width / H;
  ScriptContext c;
  c.mask = mask;
  for (const Layer& l : layers_) {
    c.k.push_back(ag::permute(ag::view(l.k->forward(tokens), {B, L, H, d}), {0, 2, 1, 3}));
    c.v.push_back(ag::permute(ag::view(l.v->forward(tokens), {B, L, H, d}), {0, 2, 1, 3}));
  }
  return c;
}

ScriptContext PostureDiffuser::encode(const Tensor& ids, const Tensor& mask) const {
  return context_from_tokens(script_->forward(ids, mask).tokens, mask);
}

ScriptContext PostureDiffuser::null_context(int64_t B) const {
  const ag::Variable tok = ag::expand(ag::view(null_tok_, {1, 1, cfg_.text_dim}), {B, 1, cfg_.text_dim});
  return context_from_tokens(tok, Tensor());
}

ScriptContext PostureDiffuser::encode_with_drop(const Tensor& ids, const Tensor& mask, const Tensor& drop) const {
  if (!drop.defined()) return encode(ids, mask);
  const int64_t B = ids.size(0), L = ids.size(1);
  if (drop.dim() != 1 || drop.size(0) != B)
    throw Error("PostureDiffuser: drop must be (B) = [" + std::to_string(B) + "], got " + shape_str(drop.shape()));
  const ag::Variable tokens = script_->forward(ids, mask).tokens;
  const Tensor d = drop.to(DType::f64).contiguous();
  const Tensor cond = d.view({B, 1, 1}).to(tokens.dtype());
  const ag::Variable mixed = ag::where(cond, ag::view(null_tok_, {1, 1, cfg_.text_dim}), tokens);
  Tensor m = mask.to(DType::f64).clone();
  double* mp = m.data<double>();
  const double* dp = d.data<double>();
  for (int64_t b = 0; b < B; ++b)
    if (dp[b] != 0.0)
      for (int64_t s = 0; s < L; ++s) mp[b * L + s] = 1.0;  // all keys = null token
  return context_from_tokens(mixed, m.to(mask.dtype()));
}

ag::Variable PostureDiffuser::forward(const ag::Variable& x_t, const Tensor& t, const ScriptContext& ctx) const {
  if (x_t.dim() != 2 || x_t.size(1) != kPoseDim || !t.defined() || t.dim() != 1 || t.size(0) != x_t.size(0) ||
      (int64_t)ctx.k.size() != cfg_.layers || ctx.k[0].size(0) != x_t.size(0))
    throw Error("PostureDiffuser: x_t must be (B, " + std::to_string(kPoseDim) + ") with t (B) and a context of B "
                "rows, got x_t " + shape_str(x_t.shape()) + ", t " + (t.defined() ? shape_str(t.shape()) : "undefined") +
                ", context rows " + (ctx.k.empty() ? std::string("none") : std::to_string(ctx.k[0].size(0))));
  const int64_t B = x_t.size(0), H = cfg_.heads, d = cfg_.width / H;
  const Tensor tn = mul(t.to(DType::f64), 1.0 / (double)cfg_.diffusion_steps).to(x_t.dtype());
  const ag::Variable temb = ag::silu(t_mlp_->forward(tn));  // (B, W)
  ag::Variable h = in_->forward(x_t);
  for (size_t i = 0; i < layers_.size(); ++i) {
    const Layer& l = layers_[i];
    // residual block with the time embedding
    h = h + l.fc2->forward(ag::silu(l.fc1->forward(ag::silu(l.ln1->forward(h))) + l.t_proj->forward(temb)));
    // cross-attention: the pose feature is the one query, script tokens are keys/values
    const ag::Variable q = ag::view(l.q->forward(l.ln2->forward(h)), {B, H, 1, d});
    const ag::Variable a = ag::attention(q, ctx.k[i], ctx.v[i], ctx.mask);  // (B, H, 1, d)
    h = h + l.o->forward(ag::reshape(a, {B, cfg_.width}));
    h = h + l.mlp2->forward(ag::gelu_tanh(l.mlp1->forward(l.ln3->forward(h))));
  }
  return out_->forward(out_norm_->forward(h));
}

}  // namespace t2m::promotion
