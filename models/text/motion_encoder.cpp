// motion_encoder.cpp — patchify, input projection + learned positions, pre-LN transformer, masked-mean pooling.
#include "models/text/motion_encoder.h"

#include <string>

#include "autograd/ops_elementwise.h"
#include "autograd/ops_join.h"
#include "autograd/ops_shape.h"
#include "models/text/text_encoder.h"
#include "tensor/ops.h"

namespace t2m::text {

namespace {

int64_t get_int(const nlohmann::json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number_integer())
    throw Error(std::string("MotionEncoder: config field '") + key + "' missing or not an integer in " + j.dump());
  return j[key].get<int64_t>();
}

}  // namespace

nlohmann::json MotionEncoderConfig::to_json() const {
  return {{"feature_dim", feature_dim}, {"patch", patch},        {"dim", dim},
          {"layers", layers},           {"heads", heads},        {"mlp_ratio", mlp_ratio},
          {"max_patches", max_patches}, {"embed_dim", embed_dim}};
}

MotionEncoderConfig MotionEncoderConfig::from_json(const nlohmann::json& j) {
  MotionEncoderConfig c;
  c.feature_dim = get_int(j, "feature_dim");
  c.patch = get_int(j, "patch");
  c.dim = get_int(j, "dim");
  c.layers = get_int(j, "layers");
  c.heads = get_int(j, "heads");
  c.mlp_ratio = get_int(j, "mlp_ratio");
  c.max_patches = get_int(j, "max_patches");
  c.embed_dim = get_int(j, "embed_dim");
  c.validate();
  return c;
}

void MotionEncoderConfig::validate() const {
  if (feature_dim < 1 || patch < 1 || dim < 1 || layers < 1 || heads < 1 || mlp_ratio < 1 || max_patches < 1 ||
      embed_dim < 1)
    throw Error("MotionEncoder: every config size must be >= 1, got " + to_json().dump());
  if (dim % heads != 0)
    throw Error("MotionEncoder: dim " + std::to_string(dim) + " is not divisible by heads " + std::to_string(heads));
}

Patches patchify(const ag::Variable& x, const Tensor& mask, int64_t patch, int64_t feature_dim, const char* who) {
  if (!x.defined() || x.dim() != 3 || x.size(2) != feature_dim || x.size(1) < 1 || x.size(0) < 1 ||
      x.dtype() == DType::i64)
    throw Error(std::string(who) + ": x must be a float (B, T, " + std::to_string(feature_dim) + ") tensor, got " +
                (x.defined() ? shape_str(x.shape()) : std::string("undefined")));
  const int64_t B = x.size(0), T = x.size(1);
  if (!mask.defined() || mask.dim() != 2 || mask.size(0) != B || mask.size(1) != T || mask.dtype() == DType::i64)
    throw Error(std::string(who) + ": mask must be a float (B, T) tensor matching x " + shape_str(x.shape()) +
                ", got " + (mask.defined() ? shape_str(mask.shape()) : std::string("undefined")));
  const int64_t P = (T + patch - 1) / patch, Tp = P * patch;
  Tensor m = mask.to(x.dtype()).contiguous();
  ag::Variable xm = x * ag::Variable(m.unsqueeze(2));  // padding values never reach the model
  if (Tp != T) {
    xm = ag::concat({xm, ag::Variable(Tensor::zeros({B, Tp - T, feature_dim}, x.dtype()))}, 1);
    m = t2m::concat({m, Tensor::zeros({B, Tp - T}, x.dtype())}, 1);
  }
  Patches out;
  out.x = ag::reshape(xm, {B, P, patch * feature_dim});
  out.mask = t2m::amax(m.reshape({B, P, patch}), {2});  // (B, P)
  return out;
}

MotionEncoder::MotionEncoder(const MotionEncoderConfig& cfg, Generator& gen) : cfg_(cfg) {
  cfg_.validate();
  in_proj_ =
      register_module("in_proj", std::make_shared<nn::Linear>(cfg_.patch * cfg_.feature_dim, cfg_.dim, true, gen));
  pos_ = register_parameter("pos_emb", rand_normal({cfg_.max_patches, cfg_.dim}, gen, 0.0, 0.02));
  nn::TransformerBlockConfig bc;
  bc.dim = cfg_.dim, bc.heads = cfg_.heads, bc.mlp_ratio = cfg_.mlp_ratio;
  for (int64_t l = 0; l < cfg_.layers; ++l)
    blocks_.push_back(register_module("block" + std::to_string(l), std::make_shared<nn::TransformerBlock>(bc, gen)));
  norm_ = register_module("norm", std::make_shared<nn::LayerNorm>(cfg_.dim));
  proj_ = register_module("proj", std::make_shared<nn::Linear>(cfg_.dim, cfg_.embed_dim, true, gen));
}

ag::Variable MotionEncoder::forward(const ag::Variable& x, const Tensor& mask) const {
  Patches p = patchify(x, mask, cfg_.patch, cfg_.feature_dim, "MotionEncoder");
  const int64_t P = p.x.size(1);
  if (P > cfg_.max_patches)
    throw Error("MotionEncoder: " + std::to_string(x.size(1)) + " frames give " + std::to_string(P) +
                " patches, more than max_patches " + std::to_string(cfg_.max_patches));
  ag::Variable h = in_proj_->forward(p.x) + ag::slice(pos_, 0, 0, P);
  for (const auto& b : blocks_) h = b->forward(h, p.mask);
  return proj_->forward(masked_mean(norm_->forward(h), p.mask, "MotionEncoder"));
}

}  // namespace t2m::text
