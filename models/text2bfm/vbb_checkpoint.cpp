// vbb_checkpoint.cpp — VBB weights + config in one checkpoint file (see vbb_checkpoint.h).
#include "models/text2bfm/vbb_checkpoint.h"

#include "nn/checkpoint.h"

namespace t2m::text2bfm {

#define T2M_VBB_CKPT_FIELDS(X) X(in_dim) X(width) X(latent) X(levels) X(depth) X(growth) X(groups) X(dropout)

nlohmann::json vbb_config_json(const VbbConfig& c) {
  nlohmann::json j = nlohmann::json::object();
#define X(f) j[#f] = c.f;
  T2M_VBB_CKPT_FIELDS(X)
#undef X
  return j;
}

VbbConfig parse_vbb_config(const nlohmann::json& j) {
  if (!j.is_object()) throw Error("vbb: config must be a JSON object, got " + j.dump());
  VbbConfig c;
  try {
#define X(f) \
  if (j.contains(#f)) c.f = j.at(#f).get<decltype(c.f)>();
    T2M_VBB_CKPT_FIELDS(X)
#undef X
  } catch (const nlohmann::json::exception& e) {
    throw Error(std::string("vbb: bad config value: ") + e.what());
  }
  c.validate();
  return c;
}

void save_vbb(const Vbb& vbb, const std::string& path, const nlohmann::json& info) {
  nn::Checkpoint ck;
  ck.meta = {{"format", "t2m-vbb-1"}, {"config", vbb_config_json(vbb.config())}, {"info", info}};
  vbb.save_to(ck, "vbb.");
  ck.save(path);
}

std::unique_ptr<Vbb> load_vbb(const std::string& path, nlohmann::json* info) {
  const nn::Checkpoint ck = nn::Checkpoint::load(path);
  const std::string where = "vbb checkpoint " + path + ": ";
  if (!ck.meta.is_object() || ck.meta.value("format", std::string()) != "t2m-vbb-1")
    throw Error(where + "not a VBB checkpoint (format tag is not t2m-vbb-1)");
  VbbConfig cfg;
  try {
    cfg = parse_vbb_config(ck.meta.at("config"));
  } catch (const std::exception& e) {
    throw Error(where + "bad config: " + e.what());
  }
  Generator g(0);
  auto vbb = std::make_unique<Vbb>(cfg, g);
  try {
    vbb->load_from(ck, "vbb.");
  } catch (const std::exception& e) {
    throw Error(where + e.what());
  }
  if (ck.size() != vbb->named_parameters().size())
    throw Error(where + "holds " + std::to_string(ck.size()) + " tensors, the config has " +
                std::to_string(vbb->named_parameters().size()) + " parameters");
  vbb->eval();
  if (info) *info = ck.meta.value("info", nlohmann::json::object());
  return vbb;
}

}  // namespace t2m::text2bfm
