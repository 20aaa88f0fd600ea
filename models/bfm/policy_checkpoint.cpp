// policy_checkpoint.cpp — actor + B + config of a trained FbAgent in one file (see policy_checkpoint.h).
#include "models/bfm/policy_checkpoint.h"

#include <cstdint>
#include <cstdio>
#include <set>

#include "nn/checkpoint.h"
#include "nn/fnv1a.h"

namespace t2m::bfm {

bool is_policy_parameter(const std::string& name) {
  return name.rfind("actor.", 0) == 0 || name.rfind("B.", 0) == 0;
}

std::string latent_space_checksum(const FbAgent& agent) {
  uint64_t h = nn::kFnv1aBfmOffset;  // the offset of the generators' recorded checksums (nn/fnv1a.h)
  const auto mix = [&h](const void* p, size_t n) { h = nn::fnv1a64(p, n, h); };
  const int64_t window = agent.config().track_window;
  mix(&window, sizeof window);
  for (const auto& [name, v] : agent.named_parameters()) {
    if (name.rfind("B.", 0) != 0) continue;
    mix(name.data(), name.size() + 1);  // with the terminating zero: names and bytes cannot run together
    const Tensor t = v.data().to(DType::f32).contiguous();
    for (const int64_t d : t.shape()) mix(&d, sizeof d);
    mix(t.data<float>(), sizeof(float) * (size_t)t.numel());
  }
  return nn::fnv1a_hex(h);
}

void save_policy(const FbAgent& agent, const std::string& path, const nlohmann::json& info) {
  nn::Checkpoint ck;
  ck.meta = {{"format", "t2m-bfm-policy-1"}, {"fb", agent.config().to_json()}, {"info", info}};
  for (const auto& [name, v] : agent.named_parameters())
    if (is_policy_parameter(name)) ck.put(name, v.data());
  ck.save(path);
}

std::unique_ptr<FbAgent> load_policy(const std::string& path, nlohmann::json* info) {
  const nn::Checkpoint ck = nn::Checkpoint::load(path);
  const std::string where = "bfm policy " + path + ": ";
  if (!ck.meta.is_object() || ck.meta.value("format", std::string()) != "t2m-bfm-policy-1")
    throw Error(where + "not a BFM policy file (format tag is not t2m-bfm-policy-1)");
  FbConfig cfg;
  try {
    cfg = FbConfig::from_json(ck.meta.at("fb"));
    cfg.validate();
  } catch (const std::exception& e) {
    throw Error(where + "bad config: " + e.what());
  }
  auto agent = std::make_unique<FbAgent>(cfg, 0);
  std::set<std::string> want;
  for (const auto& [name, v] : agent->named_parameters()) {
    if (!is_policy_parameter(name)) continue;
    want.insert(name);
    if (!ck.has(name)) throw Error(where + "missing tensor '" + name + "'");
    const Tensor& t = ck.get(name);
    if (t.shape() != v.data().shape() || t.dtype() != v.data().dtype())
      throw Error(where + "tensor '" + name + "' has shape " + shape_str(t.shape()) + ", the config needs " +
                  shape_str(v.data().shape()));
  }
  for (const auto& n : ck.names())
    if (!want.count(n)) throw Error(where + "unexpected tensor '" + n + "'");
  for (const auto& [name, v] : agent->named_parameters())
    if (is_policy_parameter(name)) v.data().copy_(ck.get(name));
  agent->eval();
  if (info) *info = ck.meta.value("info", nlohmann::json::object());
  return agent;
}

}  // namespace t2m::bfm
