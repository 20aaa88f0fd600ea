// policy_checkpoint.h — a shipped BFM (models/checkpoints/bfm_*.t2mckpt; the pipeline's: bfm_stand): what the
// text-to-motion pipeline needs from a trained FbAgent, the actor pi(a | s, z) and the backward map B (for Eq 2
// latents), plus the config.
// F, the target networks and the optimizer state stay in the training state (~/.cache/t2m/bfm/...).
//
//   save_policy(agent, "models/checkpoints/bfm_small.t2mckpt", {{"updates", 20000}, ...});
//   std::unique_ptr<FbAgent> a = load_policy(path);   // actor and B loaded; F is freshly initialised (unused)
//   a->infer_tracking_z(states); a->actor_mean(obs, z); a->action_kl(...)
//
// File: nn::Checkpoint (atomic write, CRC) with the tensors "actor.*" and "B.*" of FbAgent::named_parameters()
// and meta {"format": "t2m-bfm-policy-1", "fb": FbConfig::to_json(), "info": {...free-form...}}.
// Errors (t2m::Error "bfm policy PATH: ..."): missing/corrupt file, wrong format tag, a bad config, a missing or
// extra tensor, or a shape mismatch (names the tensor).
#pragma once
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "models/bfm/fb_agent.h"

namespace t2m::bfm {

void save_policy(const FbAgent& agent, const std::string& path, const nlohmann::json& info = nlohmann::json::object());
std::unique_ptr<FbAgent> load_policy(const std::string& path, nlohmann::json* info = nullptr);

// True for the parameter names a policy checkpoint holds ("actor." and "B." prefixes).
bool is_policy_parameter(const std::string& name);

// The identity of the policy's latent space: FNV-1a 64 (16 hex digits) over the B network's parameter names, shapes
// and float32 bytes and the Eq 2 window. Policies with equal checksums give the same Eq 2 latents (an actor
// fine-tuned by `t2m train bfm-distill` keeps its B), so a VBB or generator trained on one serves the other.
std::string latent_space_checksum(const FbAgent& agent);

}  // namespace t2m::bfm
