// go_diffuser_checkpoint.h — the shipped go-diffuser file (models/checkpoints/promotion_go.t2mckpt): weights,
// config and the train-split feature stats that define the normalisation of its inputs and outputs.
// Format: nn::Checkpoint, meta {"format": "t2m-promotion-go-1", "config": GoDiffuserConfig, "train": {...}},
// tensors "model." + parameter names, "feature_mean" (257), "feature_std" (257).
// Errors (t2m::Error naming the path): not this format, malformed meta, missing/mis-shaped tensors.
#pragma once
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "models/data/features_norm.h"
#include "models/promotion/go_diffuser.h"

namespace t2m::promotion {

struct GoBundle {
  std::shared_ptr<GoDiffuser> model;
  data::FeatureStats stats;  // (257) mean / std, train split with mirrors
  nlohmann::json train = nlohmann::json::object();  // provenance: command, steps, data
};

void save_go_checkpoint(const GoBundle& b, const std::string& path);
GoBundle load_go_checkpoint(const std::string& path);

}  // namespace t2m::promotion
