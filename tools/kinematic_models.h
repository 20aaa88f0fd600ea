// kinematic_models.h — the registry of kinematic text-to-motion models that `t2m generate --model NAME` runs (the
// baselines: CASIM diffusion / autoregressive, PRO-Motion). Text2BFM itself is the default model ("text2bfm") and
// is not in this registry (it simulates; see tools/cmd_generate.cpp).
//
// A model registers itself from its own tools/gen_*.cpp:
//   t2m::cli::KinematicResult generate_casim_cls(const t2m::cli::KinematicRequest& r) { ... }
//   T2M_KINEMATIC_MODEL("casim-diff-cls", "CASIM baseline: MDM diffusion, sentence embedding", generate_casim_cls);
// `t2m generate "PROMPT" --model casim-diff-cls --out DIR` then loads nothing itself: the function gets the
// request, loads its checkpoints from r.checkpoints, and returns raw features; the command writes DIR
// (models/io/kinematic_output.h: features.npy, motion.bvh, render.mp4, metrics.json, atomically).
#pragma once
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace t2m::cli {

struct KinematicRequest {
  std::string prompt;                          // non-empty, has at least one word
  std::string checkpoints = "models/checkpoints";
  uint64_t seed = 0;
  double length_s = 0;  // 0: the model's default length
  double cfg = -1;      // < 0: the model's default guidance
  int steps = 0;        // 0: the model's default number of sampling steps
};

struct KinematicResult {
  std::vector<float> features;                      // [T, 257] raw (unnormalised) motion features
  nlohmann::json info = nlohmann::json::object();   // merged into metrics.json under "info"
};

using KinematicGenerate = KinematicResult (*)(const KinematicRequest&);

struct KinematicModel {
  std::string name, description;
  KinematicGenerate generate = nullptr;
};

// Every registered model, in registration order (static initialisation; read it after main starts).
std::vector<KinematicModel>& kinematic_models();
// The model called `name`; throws t2m::Error listing the known names when there is none.
const KinematicModel& find_kinematic_model(const std::string& name);

struct KinematicModelRegistrar {
  KinematicModelRegistrar(const char* name, const char* description, KinematicGenerate fn) {
    kinematic_models().push_back({name, description, fn});
  }
};

}  // namespace t2m::cli

#define T2M_KINEMATIC_CAT2(a, b) a##b
#define T2M_KINEMATIC_CAT(a, b) T2M_KINEMATIC_CAT2(a, b)
#define T2M_KINEMATIC_MODEL(name, description, fn) \
  static ::t2m::cli::KinematicModelRegistrar T2M_KINEMATIC_CAT(t2m_kin_reg_, __LINE__)(name, description, fn)
