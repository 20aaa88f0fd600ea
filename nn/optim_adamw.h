// optim_adamw.h — AdamW (Loshchilov & Hutter 2019, decoupled weight decay), the update order of torch.optim.AdamW:
//   p <- p (1 - lr wd);  m <- b1 m + (1 - b1) g;  v <- b2 v + (1 - b2) g^2
//   p <- p - lr (m / (1 - b1^t)) / (sqrt(v / (1 - b2^t)) + eps)          t = step_count() after the increment
// float32 parameters go through ONE fused multi-tensor call per group (tensor/fused/adamw.h: decayed group and
// no-decay group), so the update is bitwise independent of the thread count. float64 parameters (gradcheck-style
// tests) take a plain scalar loop with the same arithmetic in double.
// no_decay: a predicate on (name, parameter); where it returns true the parameter gets weight_decay 0. The
// usual choice, no_decay_1d, exempts every parameter with dim() <= 1 (biases, norm gains, logit scales).
// State slots "exp_avg" (m) and "exp_avg_sq" (v); save/check/load as in nn/optim.h.
// Errors (t2m::Error "AdamW: ..."): betas outside [0, 1), eps < 0, weight_decay < 0, plus those of nn/optim.h.
#pragma once
#include <functional>

#include "nn/optim.h"

namespace t2m::nn {

struct AdamWOptions {
  double lr = 1e-3;
  double beta1 = 0.9;
  double beta2 = 0.999;
  double eps = 1e-8;
  double weight_decay = 1e-2;
  std::function<bool(const std::string& name, const ag::Variable& p)> no_decay;  // empty: decay everything
};

// true for dim() <= 1: biases, LayerNorm/RMSNorm/GroupNorm gains, scalar parameters.
bool no_decay_1d(const std::string& name, const ag::Variable& p);

class AdamW : public Optimizer {
 public:
  AdamW(NamedParams params, AdamWOptions opt = {});
  void step() override;
  const AdamWOptions& options() const { return opt_; }
  bool decays(size_t i) const { return decay_[i]; }  // whether parameter i gets weight decay

 private:
  AdamWOptions opt_;
  std::vector<bool> decay_;
};

}  // namespace t2m::nn
