// pipeline_checkpoints.h — the checkpoint files the text-to-motion pipeline reads (models/checkpoints/; PipelinePaths
// names the set):
//
//   gen_small.t2mckpt  (written here, `t2m train gen`): nn::Checkpoint, meta {"format": "t2m-gen-1",
//     "config": flow_config_to_json(cfg), "program": {"compression": c, "latent": d_m, "window": Tm},
//     "train": {...provenance...}}, tensors "model." + FlowGenerator parameter names, "program_mean" (d_m) and
//     "program_std" (d_m) float32: the generator works on standardised programs (m - mean) / std (statistics of
//     the train-split programs), so that m(0) ~ N(0, I) (Eq 16) starts at the data's scale.
//   A generator trained with the diffusion objective (gen_train.h, Table 5's variant) also has meta "objective":
//   {"kind": "diffusion", "prediction": "v", "schedule": "cosine" | "linear"}; absent = "flow" (Eq 14-16).
//   (vbb_small.t2mckpt is models/text2bfm/vbb_checkpoint.h's file, `t2m train vbb`.)
// Config JSON: every field of FlowGeneratorConfig (adapter nested as "adapter"); from_json fills missing keys with
// defaults and rejects unknown ones.
// Errors (t2m::Error naming the file): missing/corrupt file, wrong format, bad config, missing or mis-shaped
// parameters (Module::load_from), program stats of the wrong size or with std <= 0.
#pragma once
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "models/text2bfm/generator.h"
#include "tensor/tensor.h"

namespace t2m::text2bfm {

// The four files of a pipeline set in one directory; the tools' defaults (generate, train vbb / gen, eval).
struct PipelinePaths {
  std::string text, vbb, gen, bfm;
  // DIR/text_encoder.t2mckpt, DIR/vbb_small.t2mckpt, DIR/gen_small.t2mckpt, DIR/bfm_stand.t2mckpt (since session
  // 47: bfm_distill's actor fine-tuned to start from standing, bfm_distill's B; the BFM whose
  // latent space the VBB and generator were trained on)
  static PipelinePaths in_dir(const std::string& dir);
};

nlohmann::json flow_config_to_json(const FlowGeneratorConfig& c);
FlowGeneratorConfig flow_config_from_json(const nlohmann::json& j);

// A trained generator with the program standardisation it was trained with.
struct GenBundle {
  std::shared_ptr<FlowGenerator> model;
  Tensor program_mean, program_std;  // (latent) float32
  int64_t compression = 8;           // of the VBB whose programs it learned
  int64_t window = 0;                // program frames per training window
  nlohmann::json train = nlohmann::json::object();
  std::string objective = "flow";   // "flow" (Eq 15, Euler Eq 16) | "diffusion" (v-prediction, DDIM)
  std::string schedule = "cosine";  // diffusion only: nn/diffusion_schedule.h
};

void save_gen_checkpoint(const GenBundle& b, const std::string& path);
GenBundle load_gen_checkpoint(const std::string& path);  // model in eval mode

}  // namespace t2m::text2bfm
