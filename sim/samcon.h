// samcon.h — sampling-based tracking (SAMCON: Liu, Yin, van de Panne, Shao, Xu 2010, "Sampling-based contact-rich
// motion control"), built on the balance expert (sim/balance_tracker.h): a teacher that can follow clips the
// feedback expert alone falls on (walks, turns, runs), found by search rather than by a feedback law.
//
// The reference is cut into windows of `window` control steps. For each window, `samples` candidates are drawn:
// each starts from one of the `beam` states kept from the previous window (round robin) and adds a constant offset
// δ ~ N(0, sigma² I) (radians, per hinge) to the balance expert's targets for every step of the window (the
// expert's feedback still runs on top); one candidate per kept state has δ = 0. A candidate is simulated through
// the window and scored by
//   cost = Σ_steps mean_j |p_sim,j - p_ref,j|²        (world positions of the 21 tracked bodies)
// Candidates whose largest body error reaches fail_distance on any step are dropped; the `beam` cheapest survivors
// are kept. The search stops at the clip's end or when no candidate survives; the result is the cheapest kept path
// (its offsets per control step), replayed from the start and scored like track_pd (success, MPJPE, frames
// tracked, ...). Deterministic for a seed: the offsets are drawn on one thread in order, the candidates are
// simulated in parallel (OpenMP, t2m::get_num_threads()) from saved states (Env::save_state), and ties in the
// cost are broken by candidate index, so the result does not depend on the thread count.
// Cost: samples × frames control steps (512 samples: ~80 s per 6.5 s walk clip on 2 threads).
#pragma once
#include <cstdint>
#include <memory>
#include <vector>

#include "sim/balance_tracker.h"
#include "sim/pd_tracker.h"

namespace t2m::sim {

struct SamconOptions {
  int samples = 512;  // candidates per window
  int beam = 32;      // states kept per window
  int window = 3;     // control steps per window (0.1 s)
  double sigma = 0.15;  // rad, std of the per-hinge target offset
  uint64_t seed = 1;
  BalanceOptions balance;  // the feedback expert underneath (action_noise is ignored)
};

struct SamconResult {
  PdResult track;              // the replayed path, scored like track_pd (track.simulated: the qpos / qvel)
  int frames_searched = 0;     // reference frames the search reached with a surviving candidate
  std::vector<double> offset;  // [frames - 1, nu] target offset of each control step of the path (rad)
  std::vector<double> ctrl;    // [frames - 1, nu] the actuator targets applied (expert + offset, clamped)
};

// Errors (t2m::Error): a reference that does not match the humanoid; samples < 1, beam < 1, beam > samples,
// window < 1, sigma < 0 or not finite.
SamconResult track_samcon(const std::shared_ptr<const Humanoid>& h, const QposTrajectory& ref,
                          const SamconOptions& opt = {}, const PdOptions& pd = {});

}  // namespace t2m::sim
