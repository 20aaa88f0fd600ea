// fb_config.cpp — FbConfig validation and its JSON form (recorded in every training state).
#include <string>

#include "models/bfm/fb_agent.h"

namespace t2m::bfm {

#define T2M_FB_CONFIG_FIELDS(X)                                                                                  \
  X(obs_dim) X(action_dim) X(z_dim) X(hidden) X(b_hidden) X(ensemble) X(discount) X(tau) X(ortho_coef)          \
  X(pessimism) X(bc_coef) X(q_normalize) X(actor_std) X(actor_clip) X(lr_fb) X(lr_actor) X(weight_decay)        \
  X(track_window)

nlohmann::json FbConfig::to_json() const {
  nlohmann::json j = nlohmann::json::object();
#define X(f) j[#f] = f;
  T2M_FB_CONFIG_FIELDS(X)
#undef X
  return j;
}

FbConfig FbConfig::from_json(const nlohmann::json& j) {
  if (!j.is_object()) throw Error("FbAgent: config must be a JSON object, got " + j.dump());
  FbConfig c;
  for (const auto& [k, v] : j.items()) {
    bool known = false;
    try {
#define X(f) \
  if (k == #f) { c.f = v.get<decltype(c.f)>(); known = true; }
      T2M_FB_CONFIG_FIELDS(X)
#undef X
    } catch (const nlohmann::json::exception&) {
      throw Error("FbAgent: config key '" + k + "' has a bad value " + v.dump());
    }
    if (!known) throw Error("FbAgent: unknown config key '" + k + "'");
  }
  c.validate();
  return c;
}

void FbConfig::validate() const {
  auto bad = [](const std::string& what) { throw Error("FbAgent: config " + what); };
  if (obs_dim < 1 || action_dim < 1 || z_dim < 1)
    bad("dims must be >= 1 (obs_dim " + std::to_string(obs_dim) + ", action_dim " + std::to_string(action_dim) +
        ", z_dim " + std::to_string(z_dim) + ")");
  if (hidden < 2 || hidden % 2 || b_hidden < 1) bad("hidden must be even >= 2 and b_hidden >= 1");
  if (ensemble < 1) bad("ensemble must be >= 1, got " + std::to_string(ensemble));
  if (!(discount >= 0 && discount <= 1)) bad("discount must be in [0, 1], got " + std::to_string(discount));
  if (!(tau >= 0 && tau <= 1)) bad("tau must be in [0, 1], got " + std::to_string(tau));
  if (!(ortho_coef >= 0) || !(pessimism >= 0) || !(bc_coef >= 0)) bad("ortho_coef, pessimism, bc_coef must be >= 0");
  if (!(actor_std >= 0) || !(actor_clip >= 0)) bad("actor_std and actor_clip must be >= 0");
  if (!(lr_fb >= 0) || !(lr_actor >= 0) || !(weight_decay >= 0)) bad("learning rates and weight_decay must be >= 0");
  if (track_window < 1) bad("track_window must be >= 1, got " + std::to_string(track_window));
}

}  // namespace t2m::bfm
