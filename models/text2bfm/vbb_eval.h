// vbb_eval.h — how well a bottleneck reconstructs the policy latents of a split (Text2BFM Table 4 columns):
// latent reconstruction error and the action KL of Eq 21 under the frozen BFM actor.
//
// Every clip of the set is cut into consecutive windows of `window` frames (the training length); the last
// window of a clip is right-padded by repeating its last frame and those padded frames are not scored. Each
// window is reconstructed, and over all real frames t of all clips:
//   latent_mse = mean_t ||z_t − ẑ_t||²                                  (per-frame squared norm, as in Eq 5)
//   action_kl  = mean_t KL(π(·|s_t, ẑ_t) || π(·|s_t, z_t))             (Eq 21; fixed std: Σ_a Δμ² / (2σ²))
// evaluate_vbb: ẑ = D_θ(μ_φ(z)) in eval mode (posterior mean, no dropout, no sampling), Eq 3–4.
// evaluate_average_pooling: the "average pooling" row: m_j = Proj(mean of the window's z in [j c, (j + 1) c)) (padding repeats the last real frame),
//   ẑ_t = m_{⌊t / c⌋} (no learning; Proj to radius sqrt(d) as Eq 2 does with its window means).
// project (evaluate_vbb: false by default, average pooling: true by default): every reconstructed ẑ_t is put on
//   the policy's sphere ‖ẑ_t‖ = sqrt(d) before it is scored, as generation does before the policy (GENERATE.md);
//   the same setting for both rows compares them fairly (docs/VBB.md "Why the VBB lost to pooling").
// agent may be null: action_kl is then NaN. Results do not depend on `batch` up to float rounding.
// Errors (t2m::Error "vbb eval: ..."): window not a positive multiple of the compression, a set of another
// z_dim, an empty set.
#pragma once
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>

#include "models/bfm/fb_agent.h"
#include "models/text2bfm/latent_cache.h"
#include "models/text2bfm/vbb.h"

namespace t2m::text2bfm {

struct VbbEvalResult {
  double latent_mse = 0, action_kl = 0;
  int64_t frames = 0, windows = 0, clips = 0;
  nlohmann::json to_json() const;
};

// reconstruct: z (B, W, d) windows -> ẑ (B, W, d).
using LatentReconstructor = std::function<Tensor(const Tensor& z)>;

VbbEvalResult evaluate_reconstruction(const LatentSet& set, int64_t window, bfm::FbAgent* agent,
                                      const LatentReconstructor& reconstruct, int64_t batch = 64);
VbbEvalResult evaluate_vbb(Vbb& vbb, const LatentSet& set, int64_t window, bfm::FbAgent* agent, int64_t batch = 64,
                           bool project = false);
VbbEvalResult evaluate_average_pooling(const LatentSet& set, int64_t compression, int64_t window,
                                       bfm::FbAgent* agent, int64_t batch = 64, bool project = true);
// Every row z_t of z (..., d) scaled to norm sqrt(d) (Eq 2's Proj); rows of norm 0 stay 0.
Tensor project_rows_to_sphere(const Tensor& z);
// One clip's latents z (T, d) through the bottleneck as generation would use its own program: m = the posterior mean
// of encode_programs (program_dataset.h: right-padded by repeating the last latent), ẑ = D_θ(m) cut to T rows, each
// put on the sphere. (T, d) float32. Errors: those of encode_programs.
Tensor reconstruct_clip_latents(const Vbb& vbb, const Tensor& z);

}  // namespace t2m::text2bfm
