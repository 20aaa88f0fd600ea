// ema.cpp — shadow copies updated in double arithmetic; apply/restore by value copies.
#include "nn/ema.h"

#include <algorithm>
#include <set>

#include "tensor/parallel.h"

namespace t2m::nn {

Ema::Ema(NamedParams params, double decay, bool warmup) : params_(std::move(params)), decay_(decay), warmup_(warmup) {
  if (!(decay >= 0 && decay <= 1)) throw Error("Ema: decay must be in [0, 1], got " + std::to_string(decay));
  std::set<std::string> names;
  for (const auto& [name, v] : params_) {
    if (name.empty() || !names.insert(name).second) throw Error("Ema: empty or duplicate parameter name '" + name + "'");
    if (!v.defined()) throw Error("Ema: parameter '" + name + "' is undefined");
    if (v.dtype() != DType::f32 && v.dtype() != DType::f64)
      throw Error("Ema: parameter '" + name + "' has dtype " + dtype_name(v.dtype()));
    shadow_.push_back(v.data().clone());
  }
}

double Ema::decay_at(int64_t t) const {
  if (!warmup_) return decay_;
  return std::min(decay_, (1.0 + (double)t) / (10.0 + (double)t));
}

namespace {

template <typename T>
void ema_update(T* s, const T* p, int64_t n, double d) {
  const int nt = n >= kParallelGrain ? get_num_threads() : 1;  // elementwise: identical for any thread count
#pragma omp parallel for schedule(static) num_threads(nt) if (nt > 1)
  for (int64_t i = 0; i < n; ++i) s[i] = (T)(d * (double)s[i] + (1.0 - d) * (double)p[i]);
}

}  // namespace

void Ema::update() {
  if (applied_) throw Error("Ema: update() while the EMA weights are applied (call restore() first)");
  const double d = decay_at(updates_);
  for (size_t i = 0; i < params_.size(); ++i) {
    const Tensor p = params_[i].second.data().contiguous();
    if (p.shape() != shadow_[i].shape() || p.dtype() != shadow_[i].dtype())
      throw Error("Ema: parameter '" + params_[i].first + "' changed to " + shape_str(p.shape()) + " " +
                  dtype_name(p.dtype()) + " (shadow " + shape_str(shadow_[i].shape()) + ")");
    if (p.dtype() == DType::f64)
      ema_update(shadow_[i].data<double>(), p.data<double>(), p.numel(), d);
    else
      ema_update(shadow_[i].data<float>(), p.data<float>(), p.numel(), d);
  }
  ++updates_;
}

void Ema::apply() {
  if (applied_) throw Error("Ema: apply() called twice without restore()");
  backup_.clear();
  for (size_t i = 0; i < params_.size(); ++i) {
    backup_.push_back(params_[i].second.data().clone());
    params_[i].second.data().copy_(shadow_[i]);
  }
  applied_ = true;
}

void Ema::restore() {
  if (!applied_) throw Error("Ema: restore() without apply()");
  for (size_t i = 0; i < params_.size(); ++i) params_[i].second.data().copy_(backup_[i]);
  backup_.clear();
  applied_ = false;
}

void Ema::save_to(Checkpoint& ck, const std::string& prefix) const {
  ck.put(prefix + "num_updates", Tensor::from_vector(std::vector<int64_t>{updates_}, {1}));
  for (size_t i = 0; i < params_.size(); ++i) ck.put(prefix + params_[i].first, shadow_[i]);
}

void Ema::check_state(const Checkpoint& ck, const std::string& prefix) const {
  const Tensor& n = ck.expect(prefix + "num_updates", {1}, DType::i64);
  if (n.to_vector<int64_t>()[0] < 0) throw Error("checkpoint " + ck.source() + ": Ema num_updates is negative");
  std::set<std::string> expected{prefix + "num_updates"};
  for (size_t i = 0; i < params_.size(); ++i) {
    ck.expect(prefix + params_[i].first, shadow_[i].shape(), shadow_[i].dtype());
    expected.insert(prefix + params_[i].first);
  }
  for (const auto& name : ck.names())
    if (name.compare(0, prefix.size(), prefix) == 0 && !expected.count(name))
      throw Error("checkpoint " + ck.source() + ": unexpected EMA tensor '" + name + "'");
}

void Ema::load_from(const Checkpoint& ck, const std::string& prefix) {
  if (applied_) throw Error("Ema: load_from() while the EMA weights are applied (call restore() first)");
  check_state(ck, prefix);
  updates_ = ck.get(prefix + "num_updates").to_vector<int64_t>()[0];
  for (size_t i = 0; i < params_.size(); ++i) shadow_[i].copy_(ck.get(prefix + params_[i].first));
}

}  // namespace t2m::nn
