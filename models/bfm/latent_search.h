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
// Elites (session 27): with elites = K > 1 the applied offset is the mean of the K best candidates' offsets
// (survivors first, then cost) instead of the single best one: a smoother choice, i.e. labels a student can fit
// (models/bfm/search_distill.h). Data collection: action_noise adds N(0, action_noise²) to every action the tracked
// body executes (clamped to [-1, 1]; DART-style, from an engine of its own: 0 draws nothing, the search unchanged), and
// `rows` receives (s_t, z_t, mu(s_t, z'_t), clip, t) for every control step the search is in charge of (the clean
// action, before noise).
// Standing start (session 47; start = TrackStart::standing): the tracked body starts at qpos0 at rest, where every
// generation starts, instead of in the clip's first state; the reference is scored moved on the floor to start where
// the body stands (sim/align_start.h; the latents are the clip's own, the observation being heading- and
// position-free), and for the first `transition` frames a body may be transition_fail_distance off (instead of
// pd.fail_distance) before a candidate is dropped or the planning stops: the search first has to get the body from
// standing into the clip's pose. Rows of such a search are the states a generation passes through.
// Errors (t2m::Error): samples, window or horizon < 1; sigma < 0 or not finite; carry outside [0, 1]; elites
// outside [1, samples]; action_noise < 0 or not finite; transition < 0; transition_fail_distance not finite or
// <= 0; references of another model or obs dim.
#pragma once
#include <cstdint>
#include <memory>
#include <vector>

#include "models/bfm/fb_agent.h"
#include "models/bfm/ref_motions.h"
#include "models/bfm/track_eval.h"
#include "sim/pd_tracker.h"

namespace t2m::bfm {

struct LatentSearchOptions {
  int samples = 64;    // candidates per window
  int window = 3;      // control steps each chosen offset drives the body (0.1 s)
  int horizon = 5;     // look-ahead in windows
  double sigma = 0.3;  // std of the offset's random step per latent coordinate (|z| = sqrt(d): ~1 per coordinate)
  double carry = 1.0;  // share of the previous window's offset new candidates start from
  uint64_t seed = 1;   // clip c draws from seed + c
  int elites = 1;      // offsets averaged into the applied one (1 = the best candidate's)
  double action_noise = 0.0;  // std of the noise on the tracked body's actions (data collection; 0 = evaluation)
  TrackStart start = TrackStart::reference;  // standing: from qpos0 at rest, the reference moved to it
  int transition = 30;                       // standing start: frames with the relaxed fail distance
  double transition_fail_distance = 1.0;     // m; the fail distance of those frames (never below pd's)
};

// The control steps the search drove (row r belongs to clip[r], frame t = frame[r], 0-based transition index).
struct SearchRows {
  std::vector<float> obs;     // [R, D]  s_t
  std::vector<float> z;       // [R, d]  z_t of Eq 2 (what the policy sees without the search)
  std::vector<float> action;  // [R, A]  mu(s_t, z'_t), the action the search chose (before action_noise)
  std::vector<int> clip;      // [R]     index into the references
  std::vector<int> frame;     // [R]
  int64_t rows() const { return (int64_t)clip.size(); }
  // Appends one row: obs [D], z [d], action [A].
  void add(const float* o, int D, const float* zz, int d, const float* a, int A, int c, int t) {
    obs.insert(obs.end(), o, o + D);
    z.insert(z.end(), zz, zz + d);
    action.insert(action.end(), a, a + A);
    clip.push_back(c);
    frame.push_back(t);
  }
};

// Throws t2m::Error on the option errors listed above (track_bfm_search checks them too).
void check_search_options(const LatentSearchOptions& opt);

// window: L of Eq 2 (0 = the agent's track_window).
std::vector<sim::PdResult> track_bfm_search(FbAgent& agent, std::shared_ptr<const sim::Humanoid> h,
                                            const RefMotions& refs, const LatentSearchOptions& opt = {},
                                            const sim::PdOptions& pd = {}, int window = 0,
                                            SearchRows* rows = nullptr);

}  // namespace t2m::bfm
