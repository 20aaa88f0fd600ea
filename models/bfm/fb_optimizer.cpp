// fb_optimizer.cpp — one fused AdamW call per group over the parameters that received a gradient.
#include "models/bfm/fb_optimizer.h"

#include <string>

#include "tensor/fused/adamw.h"

namespace t2m::bfm {

FbOptimizer::FbOptimizer(nn::NamedParams params, std::vector<int> group, double lr_fb, double lr_actor,
                         double weight_decay, double beta1, double beta2, double eps)
    : nn::Optimizer("FbAdamW", std::move(params), lr_fb, {"exp_avg", "exp_avg_sq"}),
      group_(std::move(group)), lr_actor_(lr_actor), wd_(weight_decay), b1_(beta1), b2_(beta2), eps_(eps) {
  if (group_.size() != params_.size())
    throw Error("FbOptimizer: " + std::to_string(group_.size()) + " group ids for " +
                std::to_string(params_.size()) + " parameters");
  for (size_t i = 0; i < params_.size(); ++i) {
    if (group_[i] != kFb && group_[i] != kActor)
      throw Error("FbOptimizer: parameter '" + params_[i].first + "' has group " + std::to_string(group_[i]));
    if (params_[i].second.dtype() != DType::f32)
      throw Error("FbOptimizer: parameter '" + params_[i].first + "' is not float32");
  }
  if (lr_actor < 0) throw Error("FbOptimizer: lr_actor must be >= 0");
}

void FbOptimizer::set_group_lr(int g, double lr) {
  if (g == kFb) set_lr(lr);
  else if (g == kActor && lr >= 0) lr_actor_ = lr;
  else throw Error("FbOptimizer: bad group " + std::to_string(g) + " or lr " + std::to_string(lr));
}

double FbOptimizer::group_lr(int g) const { return g == kFb ? lr_ : lr_actor_; }

void FbOptimizer::step_group(int g) {
  if (g != kFb && g != kActor) throw Error("FbOptimizer: bad group " + std::to_string(g));
  std::vector<float*> p, m, v;
  std::vector<const float*> gr;
  std::vector<int64_t> n;
  std::vector<Tensor> grads;  // keeps contiguous copies alive
  for (size_t i = 0; i < params_.size(); ++i) {
    if (group_[i] != g) continue;
    Tensor gi = grad_of(i);
    if (!gi.defined()) continue;
    grads.push_back(gi);
    p.push_back(params_[i].second.data().data<float>());
    gr.push_back(gi.data<float>());
    m.push_back(state_[0][i].data<float>());
    v.push_back(state_[1][i].data<float>());
    n.push_back(gi.numel());
  }
  if (p.empty()) return;
  fused::AdamWConfig cfg;
  cfg.lr = (float)group_lr(g);
  cfg.beta1 = (float)b1_;
  cfg.beta2 = (float)b2_;
  cfg.eps = (float)eps_;
  cfg.weight_decay = (float)wd_;
  fused::adamw_step(p.data(), gr.data(), m.data(), v.data(), n.data(), (int64_t)p.size(), cfg, step_ + 1);
}

void FbOptimizer::step() {
  step_group(kFb);
  step_group(kActor);
  finish_step();
}

}  // namespace t2m::bfm
