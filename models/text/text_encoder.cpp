// text_encoder.cpp — token embedding + learned positions, pre-LN transformer blocks, final LayerNorm, masked-mean
// pooling and projection (see text_encoder.h).
#include "models/text/text_encoder.h"

#include <string>

#include "autograd/ops_elementwise.h"
#include "autograd/ops_reduce.h"
#include "autograd/ops_shape.h"
#include "tensor/ops.h"

namespace t2m::text {

namespace {

int64_t get_int(const nlohmann::json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number_integer())
    throw Error(std::string("TextEncoder: config field '") + key + "' missing or not an integer in " + j.dump());
  return j[key].get<int64_t>();
}

}  // namespace

nlohmann::json TextEncoderConfig::to_json() const {
  return {{"vocab", vocab},         {"dim", dim},         {"layers", layers},      {"heads", heads},
          {"mlp_ratio", mlp_ratio}, {"max_len", max_len}, {"embed_dim", embed_dim}};
}

TextEncoderConfig TextEncoderConfig::from_json(const nlohmann::json& j) {
  TextEncoderConfig c;
  c.vocab = get_int(j, "vocab");
  c.dim = get_int(j, "dim");
  c.layers = get_int(j, "layers");
  c.heads = get_int(j, "heads");
  c.mlp_ratio = get_int(j, "mlp_ratio");
  c.max_len = get_int(j, "max_len");
  c.embed_dim = get_int(j, "embed_dim");
  c.validate();
  return c;
}

void TextEncoderConfig::validate() const {
  if (vocab < 1 || dim < 1 || layers < 1 || heads < 1 || mlp_ratio < 1 || max_len < 2 || embed_dim < 1)
    throw Error("TextEncoder: every config size must be >= 1 (max_len >= 2), got " + to_json().dump());
  if (dim % heads != 0)
    throw Error("TextEncoder: dim " + std::to_string(dim) + " is not divisible by heads " + std::to_string(heads));
}

ag::Variable masked_mean(const ag::Variable& x, const Tensor& mask, const char* who) {
  if (x.dim() != 3 || !mask.defined() || mask.dim() != 2 || mask.size(0) != x.size(0) || mask.size(1) != x.size(1) ||
      mask.dtype() == DType::i64)
    throw Error(std::string(who) + ": mask must be a float (B, L) tensor matching x " + shape_str(x.shape()) +
                ", got " + (mask.defined() ? shape_str(mask.shape()) : std::string("undefined")));
  const Tensor m = mask.to(x.dtype());
  const Tensor count = t2m::sum(m, {1}, true);  // (B, 1)
  const auto c = count.to(DType::f64).to_vector<double>();
  for (size_t b = 0; b < c.size(); ++b)
    if (!(c[b] > 0)) throw Error(std::string(who) + ": row " + std::to_string(b) + " of the mask has no real entry");
  const ag::Variable summed = ag::sum(x * ag::Variable(m.unsqueeze(2)), {1});  // (B, C)
  return summed / ag::Variable(count);
}

TextEncoder::TextEncoder(const TextEncoderConfig& cfg, Generator& gen) : cfg_(cfg) {
  cfg_.validate();
  tok_ = register_module("tok_emb", std::make_shared<nn::Embedding>(cfg_.vocab, cfg_.dim, gen));
  mul_(tok_->weight().data(), 0.02);
  pos_ = register_parameter("pos_emb", rand_normal({cfg_.max_len, cfg_.dim}, gen, 0.0, 0.02));
  nn::TransformerBlockConfig bc;
  bc.dim = cfg_.dim, bc.heads = cfg_.heads, bc.mlp_ratio = cfg_.mlp_ratio;
  for (int64_t l = 0; l < cfg_.layers; ++l)
    blocks_.push_back(register_module("block" + std::to_string(l), std::make_shared<nn::TransformerBlock>(bc, gen)));
  norm_ = register_module("norm", std::make_shared<nn::LayerNorm>(cfg_.dim));
  proj_ = register_module("proj", std::make_shared<nn::Linear>(cfg_.dim, cfg_.embed_dim, true, gen));
}

TextFeatures TextEncoder::forward(const Tensor& ids, const Tensor& mask) const {
  if (!ids.defined() || ids.dtype() != DType::i64 || ids.dim() != 2 || ids.size(1) < 1 || ids.size(0) < 1)
    throw Error("TextEncoder: ids must be a non-empty (B, L) int64 tensor, got " +
                (ids.defined() ? shape_str(ids.shape()) + " " + dtype_name(ids.dtype()) : std::string("undefined")));
  const int64_t L = ids.size(1);
  if (L > cfg_.max_len)
    throw Error("TextEncoder: sequence length " + std::to_string(L) + " exceeds max_len " +
                std::to_string(cfg_.max_len));
  if (!mask.defined() || mask.dim() != 2 || mask.size(0) != ids.size(0) || mask.size(1) != L ||
      mask.dtype() == DType::i64)
    throw Error("TextEncoder: mask must be a float tensor of the ids' shape " + shape_str(ids.shape()) + ", got " +
                (mask.defined() ? shape_str(mask.shape()) : std::string("undefined")));
  ag::Variable h = tok_->forward(ids) + ag::slice(pos_, 0, 0, L);  // (B, L, D) + (L, D)
  for (const auto& b : blocks_) h = b->forward(h, mask);
  TextFeatures out;
  out.tokens = norm_->forward(h);
  out.pooled = proj_->forward(masked_mean(out.tokens, mask, "TextEncoder"));
  return out;
}

}  // namespace t2m::text
