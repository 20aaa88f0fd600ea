// optim_sgd.cpp — one scalar loop per parameter, templated on float/double.
#include "nn/optim_sgd.h"

namespace t2m::nn {

SGD::SGD(NamedParams params, SGDOptions opt)
    : Optimizer("SGD", std::move(params), opt.lr, {"momentum_buffer"}), opt_(opt) {
  if (!(opt_.momentum >= 0 && opt_.momentum <= 1) || !(opt_.dampening >= 0 && opt_.dampening <= 1))
    throw Error("SGD: momentum and dampening must be in [0, 1], got momentum=" + std::to_string(opt_.momentum) +
                " dampening=" + std::to_string(opt_.dampening));
  if (!(opt_.weight_decay >= 0))
    throw Error("SGD: weight_decay must be >= 0, got " + std::to_string(opt_.weight_decay));
  if (opt_.nesterov && (opt_.momentum == 0 || opt_.dampening != 0))
    throw Error("SGD: nesterov needs momentum > 0 and dampening 0, got momentum=" + std::to_string(opt_.momentum) +
                " dampening=" + std::to_string(opt_.dampening));
}

namespace {

template <typename T>
void sgd_update(T* p, const T* g, T* b, int64_t n, const SGDOptions& o, T lr, bool first) {
  const T wd = (T)o.weight_decay, mu = (T)o.momentum, damp = (T)(1.0 - o.dampening);
  for (int64_t i = 0; i < n; ++i) {
    T gi = g[i] + wd * p[i];
    if (mu != 0) {
      b[i] = first ? gi : mu * b[i] + damp * gi;
      gi = o.nesterov ? gi + mu * b[i] : b[i];
    }
    p[i] = p[i] - lr * gi;
  }
}

}  // namespace

void SGD::step() {
  const bool first = step_ == 0;
  for (size_t i = 0; i < params_.size(); ++i) {
    Tensor g = grad_of(i);
    if (!g.defined()) continue;
    Tensor& p = params_[i].second.data();
    if (p.dtype() == DType::f64)
      sgd_update(p.data<double>(), g.data<double>(), state_[0][i].data<double>(), p.numel(), opt_, lr_, first);
    else
      sgd_update(p.data<float>(), g.data<float>(), state_[0][i].data<float>(), p.numel(), opt_, (float)lr_, first);
  }
  ++step_;
}

}  // namespace t2m::nn
