// diffusion_denoiser.cpp — the three conditioning variants of the MDM-style x0-denoiser.
#include "models/casim/diffusion_denoiser.h"

#include <cmath>
#include <set>

#include "autograd/ops_elementwise.h"
#include "autograd/ops_shape.h"
#include "tensor/ops.h"

namespace t2m::casim {

using json = nlohmann::json;

namespace {

std::string shape_str(const Shape& s) {
  std::string r = "(";
  for (size_t i = 0; i < s.size(); ++i) r += (i ? ", " : "") + std::to_string(s[i]);
  return r + ")";
}

}  // namespace

const char* conditioning_name(Conditioning c) {
  switch (c) {
    case Conditioning::cls: return "cls";
    case Conditioning::mhsa: return "mhsa";
    case Conditioning::mhca: return "mhca";
  }
  return "?";
}

Conditioning conditioning_from_name(const std::string& s) {
  if (s == "cls") return Conditioning::cls;
  if (s == "mhsa") return Conditioning::mhsa;
  if (s == "mhca") return Conditioning::mhca;
  throw Error("CasimDenoiser: unknown conditioning '" + s + "' (cls | mhsa | mhca)");
}

json DenoiserConfig::to_json() const {
  return {{"cond", conditioning_name(cond)}, {"feature_dim", feature_dim}, {"width", width},
          {"layers", layers},                 {"heads", heads},             {"mlp_ratio", mlp_ratio},
          {"freq_dim", freq_dim},             {"text_dim", text_dim},       {"pooled_dim", pooled_dim},
          {"diffusion_steps", diffusion_steps}, {"cond_dropout", cond_dropout}};
}

DenoiserConfig DenoiserConfig::from_json(const json& j) {
  if (!j.is_object()) throw Error("CasimDenoiser: config is not a JSON object");
  DenoiserConfig c;
  static const std::set<std::string> known = {"cond",      "feature_dim", "width",      "layers",
                                              "heads",     "mlp_ratio",   "freq_dim",   "text_dim",
                                              "pooled_dim", "diffusion_steps", "cond_dropout"};
  for (auto it = j.begin(); it != j.end(); ++it)
    if (!known.count(it.key())) throw Error("CasimDenoiser: unknown config field '" + it.key() + "'");
  try {
    if (j.contains("cond")) c.cond = conditioning_from_name(j.at("cond").get<std::string>());
    auto rd = [&](const char* k, int64_t& v) { if (j.contains(k)) v = j.at(k).get<int64_t>(); };
    rd("feature_dim", c.feature_dim), rd("width", c.width), rd("layers", c.layers), rd("heads", c.heads);
    rd("mlp_ratio", c.mlp_ratio), rd("freq_dim", c.freq_dim), rd("text_dim", c.text_dim);
    rd("pooled_dim", c.pooled_dim), rd("diffusion_steps", c.diffusion_steps);
    if (j.contains("cond_dropout")) c.cond_dropout = j.at("cond_dropout").get<double>();
  } catch (const json::exception& e) {
    throw Error(std::string("CasimDenoiser: malformed config: ") + e.what());
  }
  c.validate();
  return c;
}

void DenoiserConfig::validate() const {
  if (feature_dim < 1 || width < 2 || width % 2 || layers < 1 || heads < 1 || width % heads || mlp_ratio < 1 ||
      freq_dim < 2 || freq_dim % 2 || text_dim < 1 || pooled_dim < 1 || diffusion_steps < 2 ||
      !(cond_dropout >= 0 && cond_dropout < 1))
    throw Error("CasimDenoiser: bad config " + to_json().dump() +
                " (sizes >= 1, even width divisible by heads, even freq_dim, steps >= 2, 0 <= cond_dropout < 1)");
}

Tensor sinusoidal_positions(int64_t T, int64_t W, DType dtype) {
  if (T < 1 || W < 2 || W % 2) throw Error("CasimDenoiser: sinusoidal positions need T >= 1 and an even W >= 2");
  std::vector<double> v((size_t)(T * W));
  for (int64_t p = 0; p < T; ++p)
    for (int64_t i = 0; i < W / 2; ++i) {
      const double a = double(p) / std::pow(10000.0, 2.0 * double(i) / double(W));
      v[(size_t)(p * W + 2 * i)] = std::sin(a);
      v[(size_t)(p * W + 2 * i + 1)] = std::cos(a);
    }
  return Tensor::from_vector(v, {T, W}).to(dtype);
}

CasimDenoiser::CasimDenoiser(const DenoiserConfig& cfg, Generator& gen) : cfg_(cfg) {
  cfg_.validate();
  const int64_t W = cfg_.width;
  null_ = register_parameter("null", rand_normal({W}, gen, 0.0, 0.02));
  t_mlp_ = register_module("t_mlp", std::make_shared<text2bfm::TimestepMLP>(cfg_.freq_dim, W, gen));
  in_proj_ = register_module("in_proj", std::make_shared<nn::Linear>(cfg_.feature_dim, W, true, gen));
  if (cfg_.cond == Conditioning::cls)
    cond_proj_ = register_module("cls_proj", std::make_shared<nn::Linear>(cfg_.pooled_dim, W, true, gen));
  else
    cond_proj_ = register_module("tok_proj", std::make_shared<nn::Linear>(cfg_.text_dim, W, true, gen));
  for (int64_t l = 0; l < cfg_.layers; ++l) {
    const std::string name = "block" + std::to_string(l);
    if (cfg_.cond == Conditioning::mhca)
      dec_.push_back(register_module(
          name, std::make_shared<CrossAlignerBlock>(
                    CrossAlignerConfig{.dim = W, .heads = cfg_.heads, .mlp_ratio = cfg_.mlp_ratio}, gen)));
    else
      enc_.push_back(register_module(
          name, std::make_shared<nn::TransformerBlock>(
                    nn::TransformerBlockConfig{.dim = W, .heads = cfg_.heads, .mlp_ratio = cfg_.mlp_ratio}, gen)));
  }
  out_norm_ = register_module("out_norm", std::make_shared<nn::LayerNorm>(W, true, 1e-5));
  out_proj_ = register_module("out_proj", std::make_shared<nn::Linear>(W, cfg_.feature_dim, true, gen));
}

Tensor CasimDenoiser::sample_condition_drop(int64_t B, Generator& gen) const {
  return rand_bernoulli({B}, gen, cfg_.cond_dropout);
}

// MDM: the diffusion step through the sinusoidal features and an MLP; t / T so that 1000 t / T is the step scale.
ag::Variable CasimDenoiser::time_embedding(const Tensor& t, DType dtype) const {
  const Tensor tc = t.contiguous();
  Tensor r = Tensor::empty({t.size(0)}, dtype);
  for (int64_t b = 0; b < t.size(0); ++b) {
    const int64_t s = tc.data<int64_t>()[b];
    if (s < 0 || s >= cfg_.diffusion_steps)
      throw Error("CasimDenoiser: diffusion step " + std::to_string(s) + " outside [0, " +
                  std::to_string(cfg_.diffusion_steps) + ")");
    const double v = double(s) / double(cfg_.diffusion_steps);
    if (dtype == DType::f64) r.data<double>()[b] = v; else r.data<float>()[b] = float(v);
  }
  return t_mlp_->forward(r);
}

ag::Variable CasimDenoiser::forward(const ag::Variable& x_t, const Tensor& t, const DiffusionText& text,
                                    const Tensor& drop, const Tensor& frame_mask) const {
  const Shape& xs = x_t.data().shape();
  if (xs.size() != 3 || xs[2] != cfg_.feature_dim)
    throw Error("CasimDenoiser: x_t " + shape_str(xs) + " must be (B, T, " + std::to_string(cfg_.feature_dim) + ")");
  const int64_t B = xs[0], T = xs[1], W = cfg_.width;
  const DType dt = x_t.data().dtype();
  if (!t.defined() || t.dtype() != DType::i64 || t.dim() != 1 || t.size(0) != B)
    throw Error("CasimDenoiser: t must be (" + std::to_string(B) + ") int64");
  if (frame_mask.defined() && (frame_mask.dim() != 2 || frame_mask.size(0) != B || frame_mask.size(1) != T))
    throw Error("CasimDenoiser: frame_mask " + shape_str(frame_mask.shape()) + " for x_t " + shape_str(xs));
  const ag::Variable temb = time_embedding(t, dt);  // (B, W)
  ag::Variable h = in_proj_->forward(x_t) + ag::Variable(sinusoidal_positions(T, W, dt).unsqueeze(0));

  if (cfg_.cond == Conditioning::cls) {
    if (!text.pooled.defined() || text.pooled.dim() != 2 || text.pooled.size(0) != B ||
        text.pooled.size(1) != cfg_.pooled_dim)
      throw Error("CasimDenoiser: pooled must be (" + std::to_string(B) + ", " + std::to_string(cfg_.pooled_dim) +
                  ")");
    // MDM: one condition token c = temb + proj(sentence embedding) in front of the motion tokens.
    const TextCondition c = with_null_condition(ag::reshape(cond_proj_->forward(ag::Variable(text.pooled.to(dt))),
                                                            {B, 1, W}),
                                                Tensor(), null_, drop);
    const JoinedSequence j = join_text_motion(c.tokens + ag::reshape(temb, {B, 1, W}), c.mask, h, frame_mask);
    ag::Variable s = j.seq;
    for (const auto& blk : enc_) s = blk->forward(s, j.mask);
    h = motion_part(j, s);
  } else {
    if (!text.tokens.defined() || text.tokens.dim() != 3 || text.tokens.size(0) != B ||
        text.tokens.size(2) != cfg_.text_dim)
      throw Error("CasimDenoiser: tokens must be (" + std::to_string(B) + ", L, " + std::to_string(cfg_.text_dim) +
                  ")");
    // CASIM: projected token embeddings augmented with the diffusion-step embedding.
    const TextCondition c =
        with_null_condition(cond_proj_->forward(ag::Variable(text.tokens.to(dt))), text.tok_mask, null_, drop);
    const ag::Variable y = c.tokens + ag::reshape(temb, {B, 1, W});
    if (cfg_.cond == Conditioning::mhsa) {  // CASIM Eq 4
      const JoinedSequence j = join_text_motion(y, c.mask, h, frame_mask);
      ag::Variable s = j.seq;
      for (const auto& blk : enc_) s = blk->forward(s, j.mask);
      h = motion_part(j, s);
    } else {  // CASIM Eq 5
      for (const auto& blk : dec_) h = blk->forward(h, frame_mask, y, c.mask);
    }
  }
  return out_proj_->forward(out_norm_->forward(h));
}

}  // namespace t2m::casim
