// ar_gpt.cpp — prefix construction (cls / tok), the causal transformer stack and the token head.
#include "models/casim/ar_gpt.h"

#include "autograd/autograd.h"
#include "tensor/ops.h"

namespace t2m::casim {

using json = nlohmann::json;

const char* ar_cond_name(ArCond c) { return c == ArCond::cls ? "cls" : "tok"; }

ArCond ar_cond_from_name(const std::string& s) {
  if (s == "cls") return ArCond::cls;
  if (s == "tok") return ArCond::tok;
  throw Error("ar gpt: unknown conditioning '" + s + "' (cls or tok)");
}

json ArGptConfig::to_json() const {
  return {{"cond", ar_cond_name(cond)}, {"codes", codes},       {"max_motion", max_motion},
          {"text_dim", text_dim},       {"pooled_dim", pooled_dim}, {"max_text", max_text},
          {"dim", dim},                 {"layers", layers},     {"heads", heads},
          {"mlp_ratio", mlp_ratio}};
}

ArGptConfig ArGptConfig::from_json(const json& j) {
  ArGptConfig c;
  try {
    c.cond = ar_cond_from_name(j.at("cond").get<std::string>());
    c.codes = j.at("codes"), c.max_motion = j.at("max_motion"), c.text_dim = j.at("text_dim");
    c.pooled_dim = j.at("pooled_dim"), c.max_text = j.at("max_text"), c.dim = j.at("dim");
    c.layers = j.at("layers"), c.heads = j.at("heads"), c.mlp_ratio = j.at("mlp_ratio");
  } catch (const json::exception& e) {
    throw Error(std::string("ar gpt: bad config JSON: ") + e.what());
  }
  c.validate();
  return c;
}

void ArGptConfig::validate() const {
  if (codes < 1 || max_motion < 1 || text_dim < 1 || pooled_dim < 1 || max_text < 1 || dim < 1 || layers < 0 ||
      heads < 1 || dim % heads != 0 || mlp_ratio < 1)
    throw Error("ar gpt: bad config " + to_json().dump());
}

ArGpt::ArGpt(const ArGptConfig& cfg, Generator& gen) : cfg_(cfg) {
  cfg.validate();
  som_ = register_parameter("som", rand_normal({cfg.dim}, gen, 0.0, 0.02));
  motion_pos_ = register_parameter("motion_pos", rand_normal({cfg.max_motion + 1, cfg.dim}, gen, 0.0, 0.02));
  if (cfg.cond == ArCond::tok)
    text_pos_ = register_parameter("text_pos", rand_normal({cfg.max_text, cfg.dim}, gen, 0.0, 0.02));
  const int64_t tin = cfg.cond == ArCond::tok ? cfg.text_dim : cfg.pooled_dim;
  text_proj_ = register_module("text_proj", std::make_shared<nn::Linear>(tin, cfg.dim, true, gen));
  tok_emb_ = register_module("tok_emb", std::make_shared<nn::Embedding>(cfg.codes, cfg.dim, gen));
  mul_(tok_emb_->weight().data(), 0.02);
  nn::TransformerBlockConfig bc;
  bc.dim = cfg.dim, bc.heads = cfg.heads, bc.mlp_ratio = cfg.mlp_ratio, bc.causal = true;
  for (int64_t i = 0; i < cfg.layers; ++i)
    blocks_.push_back(register_module("block" + std::to_string(i), std::make_shared<nn::TransformerBlock>(bc, gen)));
  norm_ = register_module("norm", std::make_shared<nn::LayerNorm>(cfg.dim));
  head_ = register_module("head", std::make_shared<nn::Linear>(cfg.dim, cfg.codes + 1, true, gen));
}

ag::Variable ArGpt::prefix(const ArText& text, Tensor* key_mask) const {
  if (cfg_.cond == ArCond::cls) {
    const Tensor& p = text.pooled;
    if (!p.defined() || p.dim() != 2 || p.size(1) != cfg_.pooled_dim)
      throw Error("ar gpt (cls): pooled must be (B, " + std::to_string(cfg_.pooled_dim) + ")");
    *key_mask = Tensor::ones({p.size(0), 1}, p.dtype());
    return ag::unsqueeze(text_proj_->forward(ag::Variable(p)), 1);  // (B, 1, dim)
  }
  const Tensor& y = text.tokens;
  if (!y.defined() || y.dim() != 3 || y.size(2) != cfg_.text_dim || y.size(1) < 1 || y.size(1) > cfg_.max_text)
    throw Error("ar gpt (tok): tokens must be (B, L, " + std::to_string(cfg_.text_dim) + ") with 1 <= L <= " +
                std::to_string(cfg_.max_text));
  const int64_t B = y.size(0), L = y.size(1);
  if (!text.mask.defined() || text.mask.dim() != 2 || text.mask.size(0) != B || text.mask.size(1) != L)
    throw Error("ar gpt (tok): mask must be (B, L) of the tokens");
  *key_mask = text.mask.to(y.dtype());
  return text_proj_->forward(ag::Variable(y)) + ag::slice(text_pos_, 0, 0, L);  // (B, L, dim)
}

// CASIM Eq 2: logits over the next motion token given [text, c_<i].
ag::Variable ArGpt::forward(const ArText& text, const Tensor& codes) const {
  Tensor kp;
  const ag::Variable pre = prefix(text, &kp);
  const int64_t B = pre.size(0), P = pre.size(1);
  if (codes.dtype() != DType::i64 || codes.dim() != 2 || codes.size(0) != B || codes.size(1) > cfg_.max_motion)
    throw Error("ar gpt: codes must be int64 (B, n) with B = " + std::to_string(B) + " and n <= " +
                std::to_string(cfg_.max_motion));
  const int64_t n = codes.size(1);
  const DType dt = pre.dtype();
  ag::Variable som = ag::expand(ag::reshape(som_ + ag::select(motion_pos_, 0, 0), {1, 1, cfg_.dim}),
                                {B, 1, cfg_.dim});
  std::vector<ag::Variable> parts = {pre, som};
  if (n > 0) parts.push_back(tok_emb_->forward(codes) + ag::slice(motion_pos_, 0, 1, n + 1));
  ag::Variable h = ag::concat(parts, 1);
  const Tensor key_mask = concat({kp, Tensor::ones({B, n + 1}, dt)}, 1);
  for (const auto& b : blocks_) h = b->forward(h, key_mask);
  return head_->forward(norm_->forward(ag::slice(h, 1, P, P + n + 1)));
}

}  // namespace t2m::casim
