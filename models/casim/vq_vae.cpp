// vq_vae.cpp — the conv encoder/decoder around the codebook, tokenize/detokenize and the training loss.
#include "models/casim/vq_vae.h"

#include <string>

#include "autograd/autograd.h"
#include "autograd/ops_conv.h"
#include "nn/loss_regression.h"
#include "tensor/ops.h"

namespace t2m::casim {

using json = nlohmann::json;

json VqVaeConfig::to_json() const {
  return {{"feature_dim", feature_dim}, {"width", width},   {"levels", levels},
          {"depth", depth},             {"growth", growth}, {"groups", groups},
          {"codes", codebook.codes},    {"code_dim", codebook.dim},
          {"decay", codebook.decay},    {"dead_threshold", codebook.dead_threshold},
          {"vel_weight", vel_weight},   {"commit", commit}};
}

VqVaeConfig VqVaeConfig::from_json(const json& j) {
  VqVaeConfig c;
  try {
    c.feature_dim = j.at("feature_dim"), c.width = j.at("width"), c.levels = j.at("levels");
    c.depth = j.at("depth"), c.growth = j.at("growth"), c.groups = j.at("groups");
    c.codebook.codes = j.at("codes"), c.codebook.dim = j.at("code_dim"), c.codebook.decay = j.at("decay");
    c.codebook.dead_threshold = j.at("dead_threshold");
    c.vel_weight = j.at("vel_weight"), c.commit = j.at("commit");
  } catch (const json::exception& e) {
    throw Error(std::string("vq vae: bad config JSON: ") + e.what());
  }
  c.validate();
  return c;
}

void VqVaeConfig::validate() const {
  if (feature_dim < 1 || width < 1 || levels < 0 || levels > 6 || depth < 0 || growth < 1 || groups < 1 ||
      width % groups != 0 || vel_weight < 0 || commit < 0)
    throw Error("vq vae: bad config " + to_json().dump());
}

VqVae::VqVae(const VqVaeConfig& cfg, Generator& gen) : cfg_(cfg) {
  cfg.validate();
  const int64_t D = cfg.feature_dim, W = cfg.width, C = cfg.codebook.dim;
  nn::Conv1dOptions k3;
  k3.pad = 1;
  nn::Conv1dOptions k4s2;
  k4s2.stride = 2, k4s2.pad = 1;
  auto res = [&](const std::string& name, int64_t i) {
    int64_t dil = 1;
    for (int64_t r = 0; r < i; ++r) dil *= cfg.growth;
    return register_module(name, std::make_shared<nn::ResConvBlock>(W, dil, gen, cfg.groups, 0.0));
  };
  enc_in_ = register_module("enc_in", std::make_shared<nn::Conv1d>(D, W, 3, k3, gen));
  for (int64_t l = 0; l < cfg.levels; ++l) {
    const std::string s = std::to_string(l);
    down_.push_back(register_module("down" + s, std::make_shared<nn::Conv1d>(W, W, 4, k4s2, gen)));
    enc_res_.emplace_back();
    for (int64_t i = 0; i < cfg.depth; ++i) enc_res_.back().push_back(res("enc" + s + "_" + std::to_string(i), i));
  }
  enc_out_ = register_module("enc_out", std::make_shared<nn::Conv1d>(W, C, 3, k3, gen));
  quant_ = register_module("quant", std::make_shared<VqCodebook>(cfg.codebook, gen));
  dec_in_ = register_module("dec_in", std::make_shared<nn::Conv1d>(C, W, 3, k3, gen));
  for (int64_t l = 0; l < cfg.levels; ++l) {
    const std::string s = std::to_string(l);
    dec_res_.emplace_back();
    for (int64_t i = cfg.depth - 1; i >= 0; --i)
      dec_res_.back().push_back(res("dec" + s + "_" + std::to_string(cfg.depth - 1 - i), i));
    up_.push_back(register_module("up" + s, std::make_shared<nn::Conv1d>(W, W, 3, k3, gen)));
  }
  dec_mid_ = register_module("dec_mid", std::make_shared<nn::Conv1d>(W, W, 3, k3, gen));
  dec_out_ = register_module("dec_out", std::make_shared<nn::Conv1d>(W, D, 3, k3, gen));
}

ag::Variable VqVae::encode(const ag::Variable& x) const {
  const int64_t f = cfg_.downsample();
  if (x.dim() != 3 || x.size(2) != cfg_.feature_dim || x.size(1) < f || x.size(1) % f != 0)
    throw Error("vq vae: encode: x must be (B, T, " + std::to_string(cfg_.feature_dim) + ") with T a positive "
                "multiple of " + std::to_string(f) + ", got dims " + std::to_string(x.dim()) + " T " +
                std::to_string(x.dim() > 1 ? x.size(1) : 0));
  ag::Variable h = ag::relu(enc_in_->forward(ag::transpose(x, 1, 2)));
  for (size_t l = 0; l < down_.size(); ++l) {
    h = down_[l]->forward(h);
    for (const auto& b : enc_res_[l]) h = b->forward(h, dropout_gen_);
  }
  return ag::transpose(enc_out_->forward(h), 1, 2);
}

ag::Variable VqVae::decode(const ag::Variable& z_q) const {
  if (z_q.dim() != 3 || z_q.size(2) != cfg_.codebook.dim || z_q.size(1) < 1)
    throw Error("vq vae: decode: z_q must be (B, n, " + std::to_string(cfg_.codebook.dim) + ")");
  ag::Variable h = ag::relu(dec_in_->forward(ag::transpose(z_q, 1, 2)));
  for (size_t l = 0; l < up_.size(); ++l) {
    for (const auto& b : dec_res_[l]) h = b->forward(h, dropout_gen_);
    h = up_[l]->forward(ag::upsample_nearest1d(h, 2));
  }
  h = ag::relu(dec_mid_->forward(h));
  return ag::transpose(dec_out_->forward(h), 1, 2);
}

Tensor VqVae::tokenize(const Tensor& x) const {
  ag::NoGradGuard ng;
  const ag::Variable z = encode(ag::Variable(x));
  const int64_t B = z.size(0), n = z.size(1);
  return quant_->assign(z.data().reshape({B * n, cfg_.codebook.dim})).reshape({B, n});
}

Tensor VqVae::detokenize(const Tensor& ids) const {
  if (ids.dtype() != DType::i64 || ids.dim() != 2) throw Error("vq vae: detokenize: ids must be int64 (B, n)");
  ag::NoGradGuard ng;
  const int64_t B = ids.size(0), n = ids.size(1);
  const Tensor zq = quant_->lookup(ids.contiguous().reshape({B * n})).reshape({B, n, cfg_.codebook.dim});
  return decode(ag::Variable(zq)).data();
}

nn::NamedParams VqVae::trainable_parameters() const {
  nn::NamedParams out;
  for (auto& [name, p] : named_parameters())
    if (name.rfind("quant.", 0) != 0) out.emplace_back(name, p);
  return out;
}

VqStep vq_loss(const VqVae& m, const Tensor& x, const Tensor& mask) {
  const auto& cfg = m.config();
  if (mask.dim() != 2 || x.dim() != 3 || mask.size(0) != x.size(0) || mask.size(1) != x.size(1))
    throw Error("vq vae: vq_loss: mask must be (B, T) of x (B, T, D)");
  const int64_t B = x.size(0), T = x.size(1), f = cfg.downsample(), C = cfg.codebook.dim;
  const ag::Variable xv(x);
  const ag::Variable z_e = m.encode(xv);  // (B, n, C)
  const int64_t n = z_e.size(1);
  const ag::Variable z_flat = ag::reshape(z_e, {B * n, C});
  const Tensor ids = m.codebook().assign(z_flat.data());
  const ag::Variable z_q = ag::reshape(m.codebook().quantize_st(z_flat, ids), {B, n, C});
  const ag::Variable recon = m.decode(z_q);

  // Masks: frames (B, T, 1); latent frame j real iff frame j*f is real.
  const Tensor mk = mask.to(x.dtype()).contiguous();
  const Tensor lat = mk.slice(1, 0, T, f).contiguous();  // (B, n)
  nn::MseOptions mo;
  mo.weights = mk.unsqueeze(2);
  const ag::Variable rec = nn::mse_loss(recon, xv, mo);
  ag::Variable loss = rec;
  VqStep s;
  s.rec = rec.item();
  if (T > 1 && cfg.vel_weight > 0) {
    auto dt = [T](const ag::Variable& v) { return ag::slice(v, 1, 1, T) - ag::slice(v, 1, 0, T - 1); };
    nn::MseOptions mv;
    mv.weights = mk.slice(1, 1, T).unsqueeze(2);
    const ag::Variable vel = nn::mse_loss(dt(recon), dt(xv), mv);
    s.vel = vel.item();
    loss = loss + vel * cfg.vel_weight;
  }
  nn::MseOptions mc;
  mc.weights = lat.unsqueeze(2);
  const Tensor zq_data = m.codebook().lookup(ids).to(x.dtype()).reshape({B, n, C});
  const ag::Variable com = nn::mse_loss(z_e, ag::Variable(zq_data), mc);
  s.commit = com.item();
  s.loss = loss + com * cfg.commit;
  s.recon = recon;

  // Codes with -1 at padding; real rows for the EMA update.
  std::vector<int64_t> idv = ids.to_vector<int64_t>(), real;
  const std::vector<float> lv = lat.to(DType::f32).to_vector<float>();
  for (int64_t r = 0; r < B * n; ++r) {
    if (lv[r] > 0.5f) real.push_back(r);
    else idv[r] = -1;
  }
  s.ids = Tensor::from_vector(idv, {B, n});
  const Tensor ridx = Tensor::from_vector(real, {(int64_t)real.size()});
  s.z_real = index_select(z_flat.data(), 0, ridx);
  s.ids_real = index_select(ids, 0, ridx);
  return s;
}

}  // namespace t2m::casim
