// search_distill.h — distilling the evaluation-time z search (latent_search.h) into the actor (docs/BFM.md,
// session 27; `t2m train bfm-distill`). The search only chooses the latent the policy sees; its actions are the
// policy's own, mu_0(s, z'). The student is the same actor, fine-tuned to produce them from the plain Eq 2 latent:
//
//   labels  (s_t, z_t, a*_t = mu_0(s_t, z'_t))   searched rollouts (SearchRows; elites > 1 for fittable labels)
//   anchor  (s_t, z_t, mu_0(s_t, z_t))           plain Eq 2 rollouts of mu_0 on clips the search did not label
//   L = mean |mu(s, z) - a*|² + anchor_weight · mean |mu(s', z') - mu_0(s', z')|²   (AdamW on the actor only,
//       one batch of each per update, cosine learning rate to 0)
// The anchor keeps the behaviour the search did not demonstrate (locomotion) where it was.
//
//   save_search_rows(rows, names, path, meta);  SearchRows r = load_search_rows(path, D, d, A, &names);
//   SearchRows anc = plain_tracking_rows(agent, h, refs, 0.05, seed);
//   DistillStats st = fit_actor_to_search(agent, labels, anc, opt, on_update);
//
// File of a chunk of rows: nn::Checkpoint (atomic, CRC) with tensors obs [R, D], z [R, d], action [R, A]
// (float32), clip, frame [R] (int64) and meta {"format": "t2m-search-rows-1", "clips": [names], ...}.
// Errors (t2m::Error "search rows PATH: ..." / "fit_actor_to_search: ..."): a missing, truncated or corrupt file,
// another format, dims other than expected, a clip index outside its names; a fit with no label rows, bad options
// or rows of other dims than the agent's.
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/bfm/fb_agent.h"
#include "models/bfm/latent_search.h"
#include "models/bfm/ref_motions.h"
#include "sim/humanoid.h"

namespace t2m::bfm {

// Writes rows (clip indices into `names`) atomically.
void save_search_rows(const SearchRows& rows, const std::vector<std::string>& names, const std::string& path,
                      const nlohmann::json& meta = nlohmann::json::object());
// Reads a file of save_search_rows and checks its dims; names (optional) receives the clip names.
SearchRows load_search_rows(const std::string& path, int obs_dim, int z_dim, int action_dim,
                            std::vector<std::string>* names = nullptr);
// Appends src to dst (clip indices offset by clip_offset).
void append_search_rows(SearchRows& dst, const SearchRows& src, int clip_offset = 0);

// Plain Eq 2 tracking of every clip with the agent's mean plus N(0, noise²) action noise (clamped), labelled with
// the clean mean: the anchor rows. A clip stops at its first frame with a body fail_distance off (pd) or at
// divergence. Deterministic for seed (clip c from seed + c).
SearchRows plain_tracking_rows(FbAgent& agent, std::shared_ptr<const sim::Humanoid> h, const RefMotions& refs,
                               double noise, uint64_t seed, const sim::PdOptions& pd = {});

struct DistillOptions {
  int64_t updates = 6000;
  int batch = 256;             // rows of each kind per update
  double lr = 1e-4;            // peak, cosine to 0
  double anchor_weight = 1.0;  // 0: labels only
  uint64_t seed = 7;           // batch sampling
};

struct DistillStats {
  double label_rms_before = 0, label_rms_after = 0;    // RMS |mu(s, z) - a*| over (up to 4096) label rows
  double anchor_rms_before = 0, anchor_rms_after = 0;  // RMS |mu(s', z') - mu_0(s', z')| over anchor rows
};

// Fine-tunes agent's actor (its other networks untouched). on_update(u, loss) after each update (may be empty).
DistillStats fit_actor_to_search(FbAgent& agent, const SearchRows& labels, const SearchRows& anchor,
                                 const DistillOptions& opt,
                                 const std::function<void(int64_t, double)>& on_update = {});

}  // namespace t2m::bfm
