// ar_checkpoint.h — the shipped files of the autoregressive CASIM baseline: the motion tokenizer
// (casim_vq.t2mckpt) and the token GPTs (casim_ar_cls.t2mckpt, casim_ar_tok.t2mckpt).
//
// Both are nn::Checkpoint files (atomic, CRC-checked):
//   tokenizer: meta {"format": "t2m-casim-vq-1", "config": VqVaeConfig, "train": {...}}, tensors "model." + the
//              VqVae parameters (codebook and its EMA state included), "feature_mean" (257), "feature_std" (257)
//              float32 — the train-split statistics the features are normalised with;
//   GPT:       meta {"format": "t2m-casim-ar-1", "config": ArGptConfig, "vq_crc": CRC-32C of the tokenizer file the
//              GPT was trained on, "train": {...}}, tensors "model." + the ArGpt parameters.
// "train" is free-form provenance (command, steps, data set and split, timings).
// Errors (t2m::Error naming the path): not such a checkpoint (format), bad config, missing/mismatched tensors.
#pragma once
#include <cstdint>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "models/casim/ar_gpt.h"
#include "models/casim/vq_vae.h"
#include "models/data/features_norm.h"

namespace t2m::casim {

struct VqBundle {
  std::shared_ptr<VqVae> model;
  data::FeatureStats stats;
  nlohmann::json train = nlohmann::json::object();
};

struct ArBundle {
  std::shared_ptr<ArGpt> model;
  uint32_t vq_crc = 0;
  nlohmann::json train = nlohmann::json::object();
};

void save_vq(const VqBundle& b, const std::string& path);
VqBundle load_vq(const std::string& path);  // model in eval mode
void save_ar(const ArBundle& b, const std::string& path);
ArBundle load_ar(const std::string& path);  // model in eval mode

// CRC-32C of a whole file (ties a GPT to its tokenizer). Throws when unreadable.
uint32_t file_crc(const std::string& path);

}  // namespace t2m::casim
