// optim_adamw.cpp — groups float32 parameters (decay / no decay) into two fused multi-tensor calls; float64
// parameters take a scalar loop with the fused kernel's arithmetic in double.
#include "nn/optim_adamw.h"

#include <cmath>

#include "tensor/fused/adamw.h"

namespace t2m::nn {

bool no_decay_1d(const std::string&, const ag::Variable& p) { return p.dim() <= 1; }

AdamW::AdamW(NamedParams params, AdamWOptions opt)
    : Optimizer("AdamW", std::move(params), opt.lr, {"exp_avg", "exp_avg_sq"}), opt_(std::move(opt)) {
  if (!(opt_.beta1 >= 0 && opt_.beta1 < 1) || !(opt_.beta2 >= 0 && opt_.beta2 < 1))
    throw Error("AdamW: betas must be in [0, 1), got beta1=" + std::to_string(opt_.beta1) +
                " beta2=" + std::to_string(opt_.beta2));
  if (!(opt_.eps >= 0)) throw Error("AdamW: eps must be >= 0, got " + std::to_string(opt_.eps));
  if (!(opt_.weight_decay >= 0))
    throw Error("AdamW: weight_decay must be >= 0, got " + std::to_string(opt_.weight_decay));
  for (const auto& [name, v] : params_) decay_.push_back(!(opt_.no_decay && opt_.no_decay(name, v)));
}

namespace {

// One AdamW update of n doubles; same operation order as the fused float kernel.
void adamw_f64(double* p, const double* g, double* m, double* v, int64_t n, double lr, double b1, double b2,
               double eps, double wd, int64_t t) {
  const double decay = 1.0 - lr * wd;
  const double bc1 = 1.0 - std::pow(b1, (double)t), bc2 = 1.0 - std::pow(b2, (double)t);
  for (int64_t i = 0; i < n; ++i) {
    m[i] = b1 * m[i] + (1.0 - b1) * g[i];
    v[i] = b2 * v[i] + (1.0 - b2) * g[i] * g[i];
    const double den = std::sqrt(v[i] / bc2) + eps;
    p[i] = p[i] * decay - lr * (m[i] / bc1) / den;
  }
}

}  // namespace

void AdamW::step() {
  const int64_t t = step_ + 1;
  // Per float32 group (0: decayed, 1: no decay): pointer lists for one fused call. Grads are held alive here.
  struct Group {
    std::vector<float*> p, m, v;
    std::vector<const float*> g;
    std::vector<int64_t> n;
  } groups[2];
  std::vector<Tensor> grads(params_.size());
  for (size_t i = 0; i < params_.size(); ++i) {
    grads[i] = grad_of(i);
    if (!grads[i].defined()) continue;
    Tensor& p = params_[i].second.data();
    const double wd = decay_[i] ? opt_.weight_decay : 0.0;
    if (p.dtype() == DType::f64) {
      adamw_f64(p.data<double>(), grads[i].data<double>(), state_[0][i].data<double>(), state_[1][i].data<double>(),
                p.numel(), lr_, opt_.beta1, opt_.beta2, opt_.eps, wd, t);
      continue;
    }
    Group& gr = groups[decay_[i] ? 0 : 1];
    gr.p.push_back(p.data<float>());
    gr.g.push_back(grads[i].data<float>());
    gr.m.push_back(state_[0][i].data<float>());
    gr.v.push_back(state_[1][i].data<float>());
    gr.n.push_back(p.numel());
  }
  for (int k = 0; k < 2; ++k) {
    Group& gr = groups[k];
    if (gr.p.empty()) continue;
    fused::AdamWConfig cfg;
    cfg.lr = (float)lr_;
    cfg.beta1 = (float)opt_.beta1;
    cfg.beta2 = (float)opt_.beta2;
    cfg.eps = (float)opt_.eps;
    cfg.weight_decay = k == 0 ? (float)opt_.weight_decay : 0.0f;
    fused::adamw_step(gr.p.data(), gr.g.data(), gr.m.data(), gr.v.data(), gr.n.data(), (int64_t)gr.p.size(), cfg, t);
  }
  step_ = t;
}

}  // namespace t2m::nn
