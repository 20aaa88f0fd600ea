// latent_search.h — BFM tracking with an evaluation-time search over the latent z (model-predictive control in the
// BFM's latent space, the policy inside; `t2m eval track --z-search`). Every action comes from the policy
// pi(s, z); only z is chosen, by simulating the policy ahead from the body's current state.
//
// Clip c: z_t = Eq 2 on the reference states (FbAgent::infer_tracking_z, as track_bfm). At the start of every
// window of `window` control steps (reference frame t, current state s) `samples` candidate offsets δ_i in R^d are
// drawn: δ_0 = 0 (plain Eq 2 tracking), δ_1 = δ_prev (the previous window's choice), δ_i = carry δ_prev + N(0,
// sigma² I) for i >= 2. Candidate i runs the policy mean a = mu(s', z'_τ) with z'_τ = sqrt(d) (z_τ + δ_i) / |z_τ + δ_i|
// (back on the sphere of B's projection; z'_τ = z_τ exactly when δ_i = 0) for window × horizon steps from s, scored
//   cost_i = Σ_steps mean_j |p_sim,j - p_ref,j|²   (the 21 tracked bodies; sim/samcon_mpc.h's tracking cost)
// and is dropped if a body drifts fail_distance from the reference. The cheapest survivor (else the cheapest; ties
// by index) drives the tracked body for the first window only; then the next window is planned from where the body
// is. After the first failure (a body fail_distance off) the policy finishes the clip on plain Eq 2 latents.
// Scored by sim::TrackingScorer like every other controller of `t2m eval track`.
//
// Evaluation only: the search uses the simulator as its model and the reference's future body positions, i.e. it
// is a planner whose action space is the policy's latent space, reported as "BFM + z search", never as the
// policy's own tracking. Cost: samples × window × horizon control steps per window (64 × 15 per 0.1 s: ~10 s per
// 3 s clip on 2 threads). Deterministic for a seed (offsets drawn on the calling thread, clip c from seed + c;
// candidates simulated in parallel), independent of the thread count.
// Errors (t2m::Error): samples, window or horizon < 1; sigma < 0 or not finite; carry outside [0, 1]; references
// of another model or obs dim.
#pragma once
#include <cstdint>
#include <memory>
#include <vector>

#include "models/bfm/fb_agent.h"
#include "models/bfm/ref_motions.h"
#include "sim/pd_tracker.h"

namespace t2m::bfm {

struct LatentSearchOptions {
  int samples = 64;    // candidates per window
  int window = 3;      // control steps each chosen offset drives the body (0.1 s)
  int horizon = 5;     // look-ahead in windows
  double sigma = 0.3;  // std of the offset's random step per latent coordinate (|z| = sqrt(d): ~1 per coordinate)
  double carry = 1.0;  // share of the previous window's offset new candidates start from
  uint64_t seed = 1;   // clip c draws from seed + c
};

// Throws t2m::Error on the option errors listed above (track_bfm_search checks them too).
void check_search_options(const LatentSearchOptions& opt);

// window: L of Eq 2 (0 = the agent's track_window).
std::vector<sim::PdResult> track_bfm_search(FbAgent& agent, std::shared_ptr<const sim::Humanoid> h,
                                            const RefMotions& refs, const LatentSearchOptions& opt = {},
                                            const sim::PdOptions& pd = {}, int window = 0);

}  // namespace t2m::bfm
