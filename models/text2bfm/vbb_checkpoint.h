// vbb_checkpoint.h — a trained VBB on disk (models/checkpoints/vbb_small.t2mckpt): the encoder/decoder weights
// and their config, what the flow generator (Eq 14–16) and generation (decode m -> z) need.
//
// File: nn::Checkpoint (atomic, CRC) with tensors "vbb." + Vbb::named_parameters() names and meta
// {"format": "t2m-vbb-1", "config": {in_dim, width, latent, levels, depth, growth, groups, dropout},
//  "info": {...free-form provenance: command, steps, BFM checksum, scores...}}.
// load_vbb returns the model in eval mode.
// Errors (t2m::Error "vbb checkpoint PATH: ..."): missing/corrupt file, wrong format tag, bad config, a missing or
// extra tensor or a shape mismatch (those of nn::Module::load_from).
#pragma once
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "models/text2bfm/vbb.h"

namespace t2m::text2bfm {

nlohmann::json vbb_config_json(const VbbConfig& c);
VbbConfig parse_vbb_config(const nlohmann::json& j);  // missing keys keep defaults; validates

void save_vbb(const Vbb& vbb, const std::string& path, const nlohmann::json& info = nlohmann::json::object());
std::unique_ptr<Vbb> load_vbb(const std::string& path, nlohmann::json* info = nullptr);

}  // namespace t2m::text2bfm
