// track_eval.h — tracking evaluation of the BFM against the PD baseline on reference clips (`t2m eval track`).
//
// BFM tracking of clip c (Text2BFM Eq 1-2): z_{1..T-1} = FbAgent::infer_tracking_z(s_{1..T}) on the reference
// states (Eq 2, L = track_window); the body starts in the reference state (qpos[0], qvel[0]) and for t = 0..T-2
// a_t = mu(s_t, z_t) (the policy mean; s_t the SIMULATED state), one control step. Scored frame by frame with
// sim::TrackingScorer, i.e. exactly the metrics of the PD baseline (sim/pd_tracker.h): success (every body within
// fail_distance of the reference on every frame), MPJPE, root drift, fall, frames tracked.
// All clips are stepped in lockstep so the policy runs on one batch per control step (OpenMP over the envs for
// the physics); results do not depend on the thread count.
// track_bfm's results carry the simulated trajectory (PdResult::simulated: qpos/qvel of frames 0..T-1, frame 0 =
// the reference start), what `t2m eval text2bfm --tracking` scores.
// PD baseline: sim::track_pd on the same clips (OpenMP over clips); the balance expert the seed data comes from
// (sim::track_balance) likewise.
// Action KL (Text2BFM Eq 21): per clip, KL(pi(.|s_t, z^hat_t) || pi(.|s_t, z_t)) averaged over the T-1 reference
// states, with z from Eq 2 at L = track_window and z^hat from Eq 2 at another window L_hat (a sensitivity number
// for the latent sequences; FbAgent::action_kl).
// Errors (t2m::Error): references of another model or obs dim, an empty clip list.
#pragma once
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <vector>

#include "models/bfm/fb_agent.h"
#include "models/bfm/ref_motions.h"
#include "sim/balance_tracker.h"
#include "sim/pd_tracker.h"

namespace t2m::bfm {

// The reference states s_0..s_{T-1} of clip c, [T, obs_dim] (what Eq 2 encodes).
Tensor clip_states(const RefMotions& refs, int c);
// Throws t2m::Error when refs is empty, of another model than h, or (agent given) of other obs / action dims.
void check_tracking_refs(const FbAgent* agent, const sim::Humanoid& h, const RefMotions& refs);

// A clip's Eq 2 latents [T-1, d] -> the latents tracked instead, same shape (e.g. a bottleneck's reconstruction).
using TrackLatentMap = std::function<Tensor(const Tensor& z)>;
// Where the body starts: in the clip's reference state (qpos[0], qvel[0], the tracking protocol), or standing in
// the humanoid's qpos0 at rest, where text-to-motion generation starts (the scorer still compares with the
// reference from frame 0, so success and MPJPE then include the distance to the clip's start).
enum class TrackStart { reference, standing };
// window: L of Eq 2 for the latents (0 = the agent's track_window); map (optional): applied to every clip's latents
// before the rollout (Error when it changes their shape).
std::vector<sim::PdResult> track_bfm(FbAgent& agent, std::shared_ptr<const sim::Humanoid> h, const RefMotions& refs,
                                     const sim::PdOptions& opt = {}, int window = 0, const TrackLatentMap& map = {},
                                     TrackStart start = TrackStart::reference);
std::vector<sim::PdResult> track_pd_all(std::shared_ptr<const sim::Humanoid> h, const RefMotions& refs,
                                        const sim::PdOptions& opt = {});
std::vector<sim::PdResult> track_balance_all(std::shared_ptr<const sim::Humanoid> h, const RefMotions& refs,
                                             const sim::BalanceOptions& bal = {}, const sim::PdOptions& opt = {});
// Clips whose first pose, held still with zero velocity for `frames` frames, the balance expert keeps (tracking
// success): the standing poses `t2m train bfm --static-holds` teaches (OpenMP over clips). Error: frames < 2.
std::vector<int> holdable_start_clips(std::shared_ptr<const sim::Humanoid> h, const RefMotions& refs, int frames,
                                      const sim::BalanceOptions& bal = {});
// How closely the policy imitates its teacher: per actuator, the RMS over every reference state s_t (t = 0..T-2,
// the kinematic replay; z_t from Eq 2) of mu(s_t, z_t) minus the balance expert's noiseless action for frame t+1,
// in [-1, 1] action units (the DAgger label of models/bfm/collect). [A]
std::vector<double> expert_imitation_rms(FbAgent& agent, std::shared_ptr<const sim::Humanoid> h, const RefMotions& refs,
                                         const sim::BalanceOptions& bal = {});
// Per-clip Eq 21 action KL between the Eq 2 latents with windows L_hat and the agent's track_window.
std::vector<double> window_action_kl(FbAgent& agent, const RefMotions& refs, int L_hat);

// Summary over clips: {"clips", "success_rate", "fall_rate", "mpjpe_m", "root_drift_m",
// "mean_fraction_of_frames_tracked"} (means over clips, the fields of `t2m track-pd`).
nlohmann::json summarize_tracking(const std::vector<sim::PdResult>& r);
// The same summary per group of clips ({group: summary}, groups in sorted order); group[c] names clip c's group
// (e.g. its content label). Throws t2m::Error when the sizes differ.
nlohmann::json summarize_tracking_by_group(const std::vector<sim::PdResult>& r, const std::vector<std::string>& group);

}  // namespace t2m::bfm
