// go_diffuser.cpp — the go-diffuser network, its x_0 loss and the ancestral sampler with optional guidance.
#include "models/promotion/go_diffuser.h"

#include <algorithm>
#include <string>

#include "autograd/no_grad.h"
#include "autograd/ops_elementwise.h"
#include "autograd/ops_join.h"
#include "autograd/ops_shape.h"
#include "models/data/features.h"
#include "models/promotion/pose.h"
#include "nn/loss_regression.h"
#include "tensor/ops.h"

namespace t2m::promotion {

namespace {

using ag::Variable;

std::string shp(const Tensor& t) { return t.defined() ? shape_str(t.shape()) : "undefined"; }

// PE(f): the sinusoid of integer frame indices (any shape, int64) -> (..., W) float32.
Tensor frame_encoding(const Tensor& frames, int64_t width) {
  const auto f = frames.contiguous().to_vector<int64_t>();
  std::vector<float> u(f.size());
  for (size_t i = 0; i < f.size(); ++i) u[i] = (float)f[i] / 1000.f;
  Shape out = frames.shape();
  out.push_back(width);
  return text2bfm::timestep_embedding(Tensor::from_vector(u, {(int64_t)u.size()}), width).view(out);
}

}  // namespace

nlohmann::json GoDiffuserConfig::to_json() const {
  return {{"frames", frames}, {"keys", keys}, {"width", width}, {"layers", layers}, {"heads", heads},
          {"mlp_ratio", mlp_ratio}, {"diffusion_steps", diffusion_steps}, {"cond_drop", cond_drop},
          {"schedule", "cosine"}};
}

GoDiffuserConfig GoDiffuserConfig::from_json(const nlohmann::json& j) {
  GoDiffuserConfig c;
  try {
    c.frames = j.at("frames"), c.keys = j.at("keys"), c.width = j.at("width"), c.layers = j.at("layers");
    c.heads = j.at("heads"), c.mlp_ratio = j.at("mlp_ratio"), c.diffusion_steps = j.at("diffusion_steps");
    c.cond_drop = j.at("cond_drop");
  } catch (const nlohmann::json::exception& e) {
    throw Error(std::string("go_diffuser: bad config JSON: ") + e.what());
  }
  c.validate();
  return c;
}

void GoDiffuserConfig::validate() const {
  if (frames < 1 || keys < 1 || keys > frames || width < 2 || width % 2 || layers < 1 || heads < 1 ||
      width % heads || mlp_ratio < 1 || diffusion_steps < 1 || !(cond_drop >= 0 && cond_drop < 1))
    throw Error("go_diffuser: bad config " + to_json().dump() + " (sizes >= 1, keys <= frames, even width "
                "divisible by heads, 0 <= cond_drop < 1)");
}

GoDiffuser::GoDiffuser(const GoDiffuserConfig& cfg, Generator& gen)
    : cfg_(cfg), sched_(DiffusionSchedule::cosine((cfg.validate(), (int)cfg.diffusion_steps))) {
  const int64_t W = cfg.width;
  time_ = register_module("time", std::make_shared<text2bfm::TimestepMLP>(W, W, gen));
  key_in_ = register_module("key_in", std::make_shared<nn::Linear>(kPoseDim, W, true, gen));
  frame_in_ = register_module("frame_in", std::make_shared<nn::Linear>(data::kFeatureDim, W, true, gen));
  key_type_ = register_parameter("key_type", rand_normal({W}, gen, 0, 0.02));
  for (int64_t l = 0; l < cfg.layers; ++l) {
    nn::TransformerBlockConfig bc;
    bc.dim = W, bc.heads = cfg.heads, bc.mlp_ratio = cfg.mlp_ratio;
    blocks_.push_back(
        register_module("block" + std::to_string(l), std::make_shared<nn::TransformerBlock>(bc, gen)));
  }
  norm_ = register_module("norm", std::make_shared<nn::LayerNorm>(W));
  out_ = register_module("out", std::make_shared<nn::Linear>(W, data::kFeatureDim, true, gen));
}

// PRO-Motion Sec 3.4 / Fig 4 b: key poses as separate tokens next to the noised motion, transformer encoder.
Variable GoDiffuser::forward(const Variable& x_t, const Tensor& t, const Variable& keys, const Tensor& key_frames,
                             const Tensor& key_mask) const {
  const int64_t T = cfg_.frames, K = cfg_.keys, W = cfg_.width;
  const Tensor& x = x_t.data();
  if (x.dim() != 3 || x.size(1) != T || x.size(2) != data::kFeatureDim)
    throw Error("go_diffuser: x_t must be (B, " + std::to_string(T) + ", 257), got " + shp(x));
  const int64_t B = x.size(0);
  if (!t.defined() || t.dtype() != DType::i64 || t.shape() != Shape{B})
    throw Error("go_diffuser: t must be int64 (" + std::to_string(B) + "), got " + shp(t));
  if (keys.data().shape() != Shape{B, K, kPoseDim} || keys.data().dtype() != x.dtype())
    throw Error("go_diffuser: keys must be (" + std::to_string(B) + ", " + std::to_string(K) + ", 187) of x_t's "
                "dtype, got " + shp(keys.data()));
  if (!key_frames.defined() || key_frames.dtype() != DType::i64 || key_frames.shape() != Shape{B, K})
    throw Error("go_diffuser: key_frames must be int64 (B, K) = (" + std::to_string(B) + ", " + std::to_string(K) +
                "), got " + shp(key_frames));
  for (int64_t f : key_frames.contiguous().to_vector<int64_t>())
    if (f < 0 || f >= T) throw Error("go_diffuser: key frame " + std::to_string(f) + " outside [0, " +
                                     std::to_string(T) + ")");
  if (!key_mask.defined() || key_mask.shape() != Shape{B, K} || key_mask.dtype() == DType::i64)
    throw Error("go_diffuser: key_mask must be float (B, K), got " + shp(key_mask));
  const DType dt = x.dtype();
  std::vector<float> steps(B);
  const auto tv = t.contiguous().to_vector<int64_t>();
  for (int64_t b = 0; b < B; ++b) {
    if (tv[b] < 0 || tv[b] >= cfg_.diffusion_steps)
      throw Error("go_diffuser: step " + std::to_string(tv[b]) + " outside [0, " +
                  std::to_string(cfg_.diffusion_steps) + ")");
    steps[b] = (float)tv[b] / 1000.f;  // timestep_embedding scales by 1000: the sinusoid of the integer step
  }
  Variable time_tok = ag::unsqueeze(time_->forward(Tensor::from_vector(steps, {B}).to(dt)), 1);  // (B, 1, W)
  Variable key_tok = key_in_->forward(keys) + Variable(frame_encoding(key_frames, W).to(dt)) + key_type_;
  Tensor frame_ids = Tensor::arange(T, DType::i64);
  Variable frame_tok = frame_in_->forward(x_t) + Variable(frame_encoding(frame_ids, W).to(dt));  // (B, T, W)
  Variable h = ag::concat({time_tok, key_tok, frame_tok}, 1);
  const Tensor mask = concat({Tensor::ones({B, 1}), key_mask.to(DType::f32), Tensor::ones({B, T})}, 1);
  for (const auto& blk : blocks_) h = blk->forward(h, mask);
  return out_->forward(norm_->forward(ag::narrow(h, 1, 1 + K, T)));
}

Tensor GoDiffuser::sample_key_keep(int64_t batch, Generator& gen) const {
  return rand_bernoulli({batch}, gen, 1 - cfg_.cond_drop);
}

Tensor GoDiffuser::sample(const Tensor& keys, const Tensor& key_frames, Generator& gen, double guidance,
                          bool inpaint) const {
  ag::NoGradGuard ng;
  const int64_t B = keys.dim() == 3 ? keys.size(0) : 0, K = cfg_.keys, T = cfg_.frames;
  const Tensor ones = Tensor::ones({B, K});
  const Variable kv(keys);
  const std::vector<float> key_rows = inpaint ? keys.contiguous().to_vector<float>() : std::vector<float>();
  const std::vector<int64_t> key_at = inpaint ? key_frames.contiguous().to_vector<int64_t>() : std::vector<int64_t>();
  auto predict = [&](const Tensor& x, int t) {
    const Tensor tt = Tensor::full({B}, t, DType::i64);
    Tensor x0 = forward(Variable(x), tt, kv, key_frames, ones).data();
    if (guidance != 1.0) {
      const Tensor xu = forward(Variable(x), tt, kv, key_frames, Tensor::zeros({B, K})).data();
      x0 = add(xu, mul(sub(x0, xu), guidance));  // x̂_u + w (x̂_c − x̂_u)
    }
    if (!inpaint) return x0;
    x0 = x0.contiguous().clone();
    float* p = x0.data<float>();
    for (int64_t b = 0; b < B; ++b)
      for (int64_t k = 0; k < K; ++k) {
        const int64_t f = key_at[(size_t)(b * K + k)];
        if (f < 0 || f >= T) throw Error("go_diffuser: key frame " + std::to_string(f) + " outside the window");
        std::copy_n(key_rows.data() + (b * K + k) * kPoseDim, kPoseDim, p + (b * T + f) * data::kFeatureDim + kPoseFeatureBegin);
      }
    return x0;
  };
  return ddpm_sample(sched_, {B, cfg_.frames, data::kFeatureDim}, predict, gen);
}

// DDPM simple loss in x_0 form: || x̂_0(q_sample(x_0, t, eps), t, keys) − x_0 ||^2 over real frames.
Variable go_diffuser_loss(const GoDiffuser& m, const Tensor& x0, const Tensor& frame_mask, const Tensor& t,
                          const Tensor& eps, const Tensor& keys, const Tensor& key_frames, const Tensor& key_keep) {
  const int64_t B = x0.size(0), K = m.config().keys;
  if (!key_keep.defined() || key_keep.shape() != Shape{B})
    throw Error("go_diffuser: key_keep must be (" + std::to_string(B) + "), got " + shp(key_keep));
  if (!frame_mask.defined() || frame_mask.shape() != Shape{B, m.config().frames})
    throw Error("go_diffuser: frame_mask must be (B, T), got " + shp(frame_mask) + " for x0 " + shp(x0));
  const Tensor x_t = m.schedule().q_sample(x0, t, eps);
  const Tensor mask = mul(key_keep.to(DType::f32).unsqueeze(1), Tensor::ones({B, K}));
  const Variable pred = m.forward(Variable(x_t), t, Variable(keys), key_frames, mask);
  nn::MseOptions mo;
  mo.weights = frame_mask.to(x0.dtype()).unsqueeze(2);
  return nn::mse_loss(pred, Variable(x0), mo);
}

}  // namespace t2m::promotion
