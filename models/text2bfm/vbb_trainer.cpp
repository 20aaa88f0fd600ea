// vbb_trainer.cpp — batches of random latent windows, Eq 13, AdamW and the resumable state (see vbb_trainer.h).
#include "models/text2bfm/vbb_trainer.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>

#include "autograd/no_grad.h"
#include "autograd/ops_shape.h"
#include "models/bfm/fb_networks.h"
#include "models/data/captions.h"
#include "models/text2bfm/vbb_average_pool.h"
#include "models/text2bfm/vbb_checkpoint.h"
#include "nn/grad_utils.h"
#include "nn/loss_contrastive.h"
#include "nn/lr_schedule.h"

namespace t2m::text2bfm {
namespace {

[[noreturn]] void fail(const std::string& m) { throw Error("vbb train: " + m); }

}  // namespace

#define T2M_VBB_TRAIN_FIELDS(X)                                                                                    \
  X(batch) X(window) X(steps) X(warmup) X(cosine) X(lr) X(weight_decay) X(grad_clip) X(sem_dim) X(seed)          \
  X(caption_seed) X(paraphrases)
#define T2M_VBB_LOSS_FIELDS(X) X(lambda_pi) X(beta) X(lambda_sem)

nlohmann::json VbbTrainConfig::to_json() const {
  nlohmann::json j, l;
#define X(f) j[#f] = f;
  T2M_VBB_TRAIN_FIELDS(X)
#undef X
#define X(f) l[#f] = loss.f;
  T2M_VBB_LOSS_FIELDS(X)
#undef X
  l["lambda_tok"] = loss.frame_token.lambda_tok;
  l["lambda_frm"] = loss.frame_token.lambda_frm;
  j["vbb"] = vbb_config_json(vbb);
  j["loss"] = l;
  if (pool_init) j["pool_init"] = true;  // only when set: older train states keep their config
  return j;
}

VbbTrainConfig VbbTrainConfig::from_json(const nlohmann::json& j) {
  VbbTrainConfig c;
  try {
#define X(f) \
  if (j.contains(#f)) c.f = j.at(#f).get<decltype(c.f)>();
    T2M_VBB_TRAIN_FIELDS(X)
#undef X
    const nlohmann::json m = j.value("vbb", nlohmann::json::object()), l = j.value("loss", nlohmann::json::object());
    if (j.contains("vbb")) c.vbb = parse_vbb_config(m);
    if (j.contains("pool_init")) c.pool_init = j.at("pool_init").get<bool>();
#define X(f) \
  if (l.contains(#f)) c.loss.f = l.at(#f).get<decltype(c.loss.f)>();
    T2M_VBB_LOSS_FIELDS(X)
#undef X
    if (l.contains("lambda_tok")) c.loss.frame_token.lambda_tok = l.at("lambda_tok").get<double>();
    if (l.contains("lambda_frm")) c.loss.frame_token.lambda_frm = l.at("lambda_frm").get<double>();
  } catch (const nlohmann::json::exception& e) {
    fail(std::string("bad config value: ") + e.what());
  }
  return c;
}

void VbbTrainConfig::validate() const {
  vbb.validate();
  if (batch < 1 || steps < 1 || warmup < 0 || sem_dim < 1 || paraphrases < 1)
    fail("batch, steps, sem_dim and paraphrases must be >= 1 and warmup >= 0");
  if (window < 1 || window % vbb.compression() != 0)
    fail("window " + std::to_string(window) + " must be a positive multiple of the compression " +
         std::to_string(vbb.compression()));
  if (!(lr > 0) || !(weight_decay >= 0) || !(grad_clip >= 0)) fail("lr must be > 0, weight_decay and grad_clip >= 0");
  if (!(loss.lambda_pi >= 0) || !(loss.beta >= 0) || !(loss.lambda_sem >= 0))
    fail("lambda_pi, beta and lambda_sem must be >= 0");
  if (cosine && steps <= warmup) fail("steps must exceed warmup for the cosine schedule");
}

// Eq 5's frozen π(a | s, z): the BFM actor's mean per frame, its fixed log std.
FrozenActor frozen_bfm_actor(bfm::FbAgent& agent) {
  for (const auto& [name, p] : agent.named_parameters())
    if (name.rfind("actor.", 0) == 0) p.set_requires_grad(false);
  agent.eval();
  const bfm::Actor* actor = &agent.actor();
  const double log_std = std::log((double)agent.config().actor_std);
  return [actor, log_std](const ag::Variable& s, const ag::Variable& z) {
    const int64_t B = s.size(0), T = s.size(1);
    ag::Variable mu = actor->forward(ag::reshape(s, {B * T, s.size(2)}), ag::reshape(z, {B * T, z.size(2)}));
    return ActorGaussian{ag::reshape(mu, {B, T, mu.size(1)}), ag::Variable(Tensor::scalar(log_std, s.dtype()))};
  };
}

VbbTrainer::VbbTrainer(const VbbTrainConfig& cfg, const LatentSet& train, bfm::FbAgent* agent, TextFeatureFn text,
                       int64_t text_dim)
    : cfg_(cfg), data_(train), text_(std::move(text)), init_gen_(cfg.seed), data_gen_(cfg.seed + 1),
      model_gen_(cfg.seed + 2) {
  cfg_.validate();
  if (data_.clips() == 0) fail("the latent set has no clips");
  if (data_.z_dim != cfg_.vbb.in_dim)
    fail("latents have z_dim " + std::to_string(data_.z_dim) + ", the VBB in_dim is " + std::to_string(cfg_.vbb.in_dim));
  if (agent && cfg_.loss.lambda_pi > 0) {
    if (agent->config().obs_dim != data_.obs_dim || agent->config().z_dim != data_.z_dim)
      fail("the actor takes obs_dim " + std::to_string(agent->config().obs_dim) + " / z_dim " +
           std::to_string(agent->config().z_dim) + ", the latent set has " + std::to_string(data_.obs_dim) + " / " +
           std::to_string(data_.z_dim));
    actor_ = frozen_bfm_actor(*agent);
  }
  vbb_ = std::make_shared<Vbb>(cfg_.vbb, init_gen_);
  if (cfg_.pool_init) init_vbb_as_average_pooling(*vbb_);
  vbb_->train();
  for (auto& p : vbb_->named_parameters()) params_.emplace_back("vbb." + p.first, p.second);
  if (text_ && cfg_.loss.lambda_sem > 0) {
    if (text_dim < 1) fail("text_dim must be >= 1 with a text function");
    head_ = std::make_shared<VbbSemanticHead>(cfg_.vbb.latent, text_dim, cfg_.sem_dim, init_gen_);
    for (auto& p : head_->named_parameters()) params_.emplace_back("head." + p.first, p.second);
  }
  nn::AdamWOptions ao;
  ao.lr = cfg_.lr;
  ao.weight_decay = cfg_.weight_decay;
  ao.no_decay = nn::no_decay_1d;
  opt_ = std::make_unique<nn::AdamW>(params_, ao);
  ts_ = std::make_unique<nn::TrainState>(params_, cfg_.to_json());
  ts_->optimizer(*opt_).generator("init", init_gen_).generator("data", data_gen_).generator("model", model_gen_);
}

// A batch of random windows (see the header). captions receives the rows' caption texts.
VbbTargets VbbTrainer::sample_batch(std::vector<std::string>& captions) {
  const int64_t B = cfg_.batch, W = cfg_.window, d = data_.z_dim, S = data_.obs_dim;
  const Tensor u = rand_uniform({B, 3}, data_gen_).contiguous();
  const float* r = u.data<float>();
  VbbTargets t;
  t.z = Tensor::empty({B, W, d});
  t.frame_mask = Tensor::zeros({B, W});
  const bool with_states = (bool)actor_;
  if (with_states) t.states = Tensor::empty({B, W, S});
  float *z = t.z.data<float>(), *fm = t.frame_mask.data<float>(), *st = with_states ? t.states.data<float>() : nullptr;
  captions.clear();
  std::vector<int64_t> ids(B);
  std::map<std::string, int64_t> id_of;
  const int C = data_.clips();
  for (int64_t b = 0; b < B; ++b) {
    const int c = std::min(C - 1, (int)(r[b * 3] * C));
    const int64_t n = data_.frames(c), len = std::min(W, n);
    const int64_t t0 = std::min(n - len, (int64_t)(r[b * 3 + 1] * (double)(n - len + 1)));
    for (int64_t t = 0; t < W; ++t) {
      const int64_t src = t0 + std::min(t, len - 1);  // pad by repeating the last real frame
      std::copy_n(data_.z_at(c, src), d, z + (b * W + t) * d);
      if (st) std::copy_n(data_.state_at(c, src), S, st + (b * W + t) * S);
      fm[b * W + t] = t < len ? 1.f : 0.f;
    }
    const int k = std::min(cfg_.paraphrases - 1, (int)(r[b * 3 + 2] * cfg_.paraphrases));
    captions.push_back(data::make_caption(data_.content[c], data_.style[c], cfg_.caption_seed, (uint64_t)k).text);
    ids[b] = id_of.emplace(data_.content[c] + "|" + data_.style[c], (int64_t)id_of.size()).first->second;
  }
  t.program_mask = program_mask_from_frames(t.frame_mask, cfg_.vbb.compression());
  if (head_) {
    TokenFeatures f;
    {
      ag::NoGradGuard ng;
      f = text_(captions);
    }
    if (!f.tokens.defined() || f.tokens.dim() != 3 || f.tokens.size(0) != B || !f.mask.defined() ||
        f.mask.shape() != Shape{B, f.tokens.size(1)})
      fail("the text function must return tokens (B, K, D) and mask (B, K) for B = " + std::to_string(B));
    t.tokens = f.tokens;
    t.token_mask = f.mask;
    cfg_.loss.frame_token.text_ids = Tensor::from_vector(ids, {B});
  }
  return t;
}

// One update of Text2BFM Eq 13.
VbbStepStats VbbTrainer::step() {
  const nn::LrSchedule sched = cfg_.cosine ? nn::LrSchedule::warmup_cosine(cfg_.lr, cfg_.warmup, cfg_.steps, cfg_.lr / 10)
                                           : nn::LrSchedule::constant_lr(cfg_.lr, cfg_.warmup);
  std::vector<std::string> captions;
  const VbbTargets batch = sample_batch(captions);
  VbbStepStats s;
  s.lr = sched.at(ts_->step);
  opt_->set_lr(s.lr);
  opt_->zero_grad();
  const VbbOutput out = vbb_->forward(ag::Variable(batch.z), model_gen_);
  const VbbLossTerms l = vbb_loss(out, batch, actor_, head_.get(), cfg_.loss);
  l.total.backward();
  s.total = l.total.item();
  s.latent_mse = l.rec.latent_mse.item();
  s.action_kl = l.rec.action_kl.defined() ? l.rec.action_kl.item() : 0.0;
  s.kl = l.kl.item();
  s.sem = l.sem.defined() ? l.sem.item() : 0.0;
  if (!std::isfinite(s.total)) fail("non-finite loss at step " + std::to_string(ts_->step));
  s.grad_norm = cfg_.grad_clip > 0 ? nn::clip_grad_norm(params_, cfg_.grad_clip) : 0.0;
  if (!std::isfinite(s.grad_norm)) nn::check_finite_grads(params_);
  opt_->step();
  if (head_) nn::clamp_logit_scale_(head_->alpha());
  ++ts_->step;
  return s;
}

}  // namespace t2m::text2bfm
