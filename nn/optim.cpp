// optim.cpp — parameter checks, slot state allocation and checkpoint save/check/load shared by the optimizers.
#include "nn/optim.h"

#include <cmath>
#include <set>

namespace t2m::nn {

Optimizer::Optimizer(std::string kind, NamedParams params, double lr, std::vector<std::string> slot_names)
    : kind_(std::move(kind)), params_(std::move(params)), slot_names_(std::move(slot_names)) {
  set_lr(lr);
  std::set<std::string> names;
  std::set<const void*> impls;
  for (const auto& [name, v] : params_) {
    if (name.empty()) throw Error(kind_ + ": a parameter has an empty name");
    if (!names.insert(name).second) throw Error(kind_ + ": duplicate parameter name '" + name + "'");
    if (!v.defined()) throw Error(kind_ + ": parameter '" + name + "' is undefined");
    if (!impls.insert(v.impl().get()).second)
      throw Error(kind_ + ": parameter '" + name + "' is the same Variable as an earlier one");
    if (v.dtype() != DType::f32 && v.dtype() != DType::f64)
      throw Error(kind_ + ": parameter '" + name + "' has dtype " + dtype_name(v.dtype()) +
                  " (float32 or float64 expected)");
    if (!v.data().is_contiguous())
      throw Error(kind_ + ": parameter '" + name + "' " + shape_str(v.shape()) + " is not contiguous");
  }
  state_.resize(slot_names_.size());
  for (auto& slot : state_)
    for (const auto& [name, v] : params_) slot.push_back(Tensor::zeros(v.shape(), v.dtype()));
}

void Optimizer::set_lr(double lr) {
  if (!(lr >= 0) || !std::isfinite(lr)) throw Error(kind_ + ": lr must be finite and >= 0, got " + std::to_string(lr));
  lr_ = lr;
}

void Optimizer::zero_grad() {
  for (auto& kv : params_) kv.second.zero_grad();
}

const Tensor& Optimizer::state(const std::string& slot, size_t i) const {
  for (size_t s = 0; s < slot_names_.size(); ++s)
    if (slot_names_[s] == slot) {
      if (i >= params_.size())
        throw Error(kind_ + ": state index " + std::to_string(i) + " out of range (" +
                    std::to_string(params_.size()) + " parameters)");
      return state_[s][i];
    }
  throw Error(kind_ + ": no state slot '" + slot + "'");
}

Tensor Optimizer::grad_of(size_t i) const {
  const auto& [name, v] = params_[i];
  if (!v.impl()->grad.defined()) return Tensor();
  const Tensor& g = v.grad();
  if (g.shape() != v.shape() || g.dtype() != v.dtype())
    throw Error(kind_ + ": grad of '" + name + "' is " + shape_str(g.shape()) + " " + dtype_name(g.dtype()) +
                ", parameter is " + shape_str(v.shape()) + " " + dtype_name(v.dtype()));
  if (!v.data().is_contiguous())
    throw Error(kind_ + ": parameter '" + name + "' " + shape_str(v.shape()) + " is no longer contiguous");
  return g.contiguous();
}

void Optimizer::save_to(Checkpoint& ck, const std::string& prefix) const {
  ck.put(prefix + "step", Tensor::from_vector(std::vector<int64_t>{step_}, {1}));
  for (size_t s = 0; s < slot_names_.size(); ++s)
    for (size_t i = 0; i < params_.size(); ++i) ck.put(prefix + slot_names_[s] + "." + params_[i].first, state_[s][i]);
}

void Optimizer::check_state(const Checkpoint& ck, const std::string& prefix) const {
  const Tensor& st = ck.expect(prefix + "step", {1}, DType::i64);
  if (st.to_vector<int64_t>()[0] < 0)
    throw Error("checkpoint " + ck.source() + ": " + kind_ + " step is negative");
  std::set<std::string> expected{prefix + "step"};
  for (size_t s = 0; s < slot_names_.size(); ++s)
    for (size_t i = 0; i < params_.size(); ++i) {
      const std::string n = prefix + slot_names_[s] + "." + params_[i].first;
      ck.expect(n, params_[i].second.shape(), params_[i].second.dtype());
      expected.insert(n);
    }
  for (const auto& n : ck.names())
    if (n.compare(0, prefix.size(), prefix) == 0 && !expected.count(n))
      throw Error("checkpoint " + ck.source() + ": unexpected " + kind_ + " state '" + n +
                  "' (no such parameter/slot in this optimizer)");
}

void Optimizer::load_from(const Checkpoint& ck, const std::string& prefix) {
  check_state(ck, prefix);
  step_ = ck.get(prefix + "step").to_vector<int64_t>()[0];
  for (size_t s = 0; s < slot_names_.size(); ++s)
    for (size_t i = 0; i < params_.size(); ++i) state_[s][i].copy_(ck.get(prefix + slot_names_[s] + "." + params_[i].first));
}

}  // namespace t2m::nn
