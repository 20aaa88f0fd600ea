// train_state.cpp — gathers every component into one Checkpoint; load validates all before copying any.
#include "nn/train_state.h"

#include <set>

namespace t2m::nn {

namespace {
const char* kFormat = "t2m-train-state";
}

TrainState::TrainState(NamedParams params, nlohmann::json config) : params_(std::move(params)), config_(std::move(config)) {
  std::set<std::string> names;
  for (const auto& [name, v] : params_) {
    if (name.empty() || !names.insert(name).second)
      throw Error("TrainState: empty or duplicate parameter name '" + name + "'");
    if (!v.defined()) throw Error("TrainState: parameter '" + name + "' is undefined");
  }
}

TrainState& TrainState::optimizer(Optimizer& opt) {
  if (opt_) throw Error("TrainState: an optimizer is already registered");
  opt_ = &opt;
  return *this;
}

TrainState& TrainState::ema(Ema& e) {
  if (ema_) throw Error("TrainState: an EMA is already registered");
  ema_ = &e;
  return *this;
}

TrainState& TrainState::generator(const std::string& name, Generator& g) {
  if (name.empty()) throw Error("TrainState: generator name is empty");
  for (const auto& kv : gens_)
    if (kv.first == name) throw Error("TrainState: generator '" + name + "' registered twice");
  gens_.emplace_back(name, &g);
  return *this;
}

void TrainState::save(const std::string& path) const {
  Checkpoint ck;
  for (const auto& [name, v] : params_) ck.put("model." + name, v.data());
  if (opt_) opt_->save_to(ck, "optim.");
  if (ema_) ema_->save_to(ck, "ema.");
  nlohmann::json gens = nlohmann::json::object();
  for (const auto& [name, g] : gens_) gens[name] = {{"seed", g->seed()}, {"offset", g->offset()}};
  ck.meta = {{"format", kFormat}, {"version", kVersion}, {"step", step},     {"epoch", epoch},
             {"cursor", cursor},  {"config", config_},   {"generators", gens}, {"user", user},
             {"optimizer", opt_ ? opt_->kind() : std::string()}, {"ema", ema_ != nullptr}};
  ck.save(path);
}

void TrainState::load(const std::string& path) { load(Checkpoint::load(path)); }

void TrainState::load(const Checkpoint& ck) {
  const std::string where = "train state " + ck.source() + ": ";
  const auto& m = ck.meta;
  if (!m.is_object() || m.value("format", std::string()) != kFormat)
    throw Error(where + "not a training state (meta.format is not '" + kFormat + "')");
  if (m.value("version", -1) != kVersion)
    throw Error(where + "unsupported version " + m.value("version", nlohmann::json()).dump());
  for (const char* k : {"step", "epoch", "cursor", "config", "generators", "optimizer", "ema"})
    if (!m.contains(k)) throw Error(where + "meta lacks '" + k + "'");
  // Config: equal JSON, else name the first difference.
  if (m["config"] != config_) {
    const nlohmann::json patch = nlohmann::json::diff(m["config"], config_);
    const auto& op = patch.at(0);
    const std::string p = op.value("path", std::string());
    const nlohmann::json::json_pointer ptr(p);
    const std::string in_file = m["config"].contains(ptr) ? m["config"][ptr].dump() : "<absent>";
    const std::string in_run = config_.contains(ptr) ? config_[ptr].dump() : "<absent>";
    throw Error(where + "config mismatch at '" + (p.empty() ? "/" : p) + "': checkpoint has " + in_file +
                ", this run has " + in_run);
  }
  // Components present on one side only.
  const std::string kind = m["optimizer"].get<std::string>();
  const std::string want = opt_ ? opt_->kind() : std::string();
  if (kind != want)
    throw Error(where + "optimizer mismatch: checkpoint has '" + (kind.empty() ? "none" : kind) + "', this run has '" +
                (want.empty() ? "none" : want) + "'");
  if (m["ema"].get<bool>() != (ema_ != nullptr))
    throw Error(where + std::string("EMA ") + (ema_ ? "missing from the checkpoint" : "in the checkpoint but not in this run"));
  const auto& gj = m["generators"];
  for (const auto& [name, g] : gens_)
    if (!gj.contains(name)) throw Error(where + "generator '" + name + "' missing from the checkpoint");
  for (const auto& [name, _] : gj.items()) {
    bool found = false;
    for (const auto& kv : gens_) found = found || kv.first == name;
    if (!found) throw Error(where + "checkpoint has generator '" + name + "' that this run does not register");
  }
  // Tensors: presence, shape, dtype; no unknown model tensors.
  std::set<std::string> expected;
  for (const auto& [name, v] : params_) {
    ck.expect("model." + name, v.shape(), v.dtype());
    expected.insert("model." + name);
  }
  for (const auto& n : ck.names())
    if (n.compare(0, 6, "model.") == 0 && !expected.count(n))
      throw Error(where + "unexpected model tensor '" + n + "' (not a parameter of this model)");
  if (opt_) opt_->check_state(ck, "optim.");
  if (ema_) ema_->check_state(ck, "ema.");
  if (ema_ && ema_->applied()) throw Error(where + "cannot load while the EMA weights are applied");
  // All checks passed: copy.
  for (const auto& [name, v] : params_) v.data().copy_(ck.get("model." + name));
  if (opt_) opt_->load_from(ck, "optim.");
  if (ema_) ema_->load_from(ck, "ema.");
  for (const auto& [name, g] : gens_) g->set_state(gj[name].at("seed").get<uint64_t>(), gj[name].at("offset").get<uint64_t>());
  step = m["step"].get<int64_t>();
  epoch = m["epoch"].get<int64_t>();
  cursor = m["cursor"].get<int64_t>();
  user = m.value("user", nlohmann::json::object());
}

}  // namespace t2m::nn
