// diffusion_checkpoint.h — a trained CASIM-MDM diffusion model as one file (models/checkpoints/casim_diff_*.t2mckpt)
// and the generation defaults it carries.
//
// File (nn::Checkpoint, atomic): meta {"format": "t2m-casim-diff-1", "config": DenoiserConfig::to_json(),
//   "window": W (training window, frames = the default generation length), "sampler": {"steps", "eta",
//   "guidance"}, "train": {...provenance...}}; tensors "model." + CasimDenoiser parameter names, "feature_mean"
//   (F) and "feature_std" (F) float32: the train-split statistics the model's feature space is normalised with.
// The cosine schedule is not stored: it is a pure function of config.diffusion_steps (diffusion_schedule.h).
// Errors (t2m::Error naming the file): missing/corrupt file, another format, bad config, stats of the wrong size
//   or with std <= 0, missing or mis-shaped parameters (Module::load_from).
#pragma once
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "models/casim/diffusion_denoiser.h"
#include "models/casim/diffusion_sampler.h"
#include "models/data/features_norm.h"

namespace t2m::casim {

struct DiffusionBundle {
  std::shared_ptr<CasimDenoiser> model;
  data::FeatureStats stats;  // train split
  int64_t window = 128;      // training window (frames)
  SamplerOptions sampler;    // generation defaults
  nlohmann::json train = nlohmann::json::object();
};

void save_diffusion_checkpoint(const DiffusionBundle& b, const std::string& path);
DiffusionBundle load_diffusion_checkpoint(const std::string& path);  // model in eval mode

}  // namespace t2m::casim
