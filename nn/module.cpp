// module.cpp — parameter registry, recursion over children, state save/load.
#include "nn/module.h"

#include <set>

namespace t2m::nn {

void Module::check_name(const std::string& name) const {
  if (name.empty() || name.find('.') != std::string::npos)
    throw Error("Module: invalid name '" + name + "' (non-empty, no dots)");
  for (const auto& p : params_)
    if (p.first == name) throw Error("Module: duplicate name '" + name + "'");
  for (const auto& c : children_)
    if (c.first == name) throw Error("Module: duplicate name '" + name + "'");
}

ag::Variable Module::register_parameter(const std::string& name, Tensor init) {
  check_name(name);
  if (!init.defined()) throw Error("Module: parameter '" + name + "' is undefined");
  ag::Variable v = ag::Variable::parameter(init.contiguous(), name);
  params_.emplace_back(name, v);
  return v;
}

void Module::add_child(const std::string& name, std::shared_ptr<Module> m) {
  check_name(name);
  if (!m) throw Error("Module: child '" + name + "' is null");
  children_.emplace_back(name, std::move(m));
}

std::vector<std::pair<std::string, ag::Variable>> Module::named_parameters() const {
  std::vector<std::pair<std::string, ag::Variable>> out = params_;
  for (const auto& [cname, child] : children_)
    for (auto& [pname, v] : child->named_parameters()) out.emplace_back(cname + "." + pname, v);
  return out;
}

std::vector<ag::Variable> Module::parameters() const {
  std::vector<ag::Variable> out;
  for (auto& kv : named_parameters()) out.push_back(kv.second);
  return out;
}

int64_t Module::num_parameters() const {
  int64_t n = 0;
  for (const auto& v : parameters()) n += v.numel();
  return n;
}

void Module::train(bool on) {
  training_ = on;
  for (auto& c : children_) c.second->train(on);
}

void Module::zero_grad() {
  for (auto& v : parameters()) v.zero_grad();
}

void Module::save_to(Checkpoint& ck, const std::string& prefix) const {
  for (const auto& [name, v] : named_parameters()) ck.put(prefix + name, v.data());
}

void Module::load_from(const Checkpoint& ck, const std::string& prefix) {
  std::set<std::string> expected;
  for (auto& [name, v] : named_parameters()) {
    const Tensor& t = ck.expect(prefix + name, v.shape(), v.dtype());
    v.data().copy_(t);
    expected.insert(prefix + name);
  }
  for (const auto& n : ck.names())
    if (n.compare(0, prefix.size(), prefix) == 0 && !expected.count(n))
      throw Error("checkpoint " + ck.source() + ": unexpected tensor '" + n + "' for this model");
}

void Module::to(DType dtype) {
  for (auto& v : parameters()) v.set_data(v.data().to(dtype));
}

}  // namespace t2m::nn
