// samcon_mpc.h — receding-horizon SAMCON: the sampling search of sim/samcon.h run in closed loop, from the state
// the body is actually in, one 0.1 s window at a time (model-predictive control with the simulator as the model).
// A teacher that walks and that can answer for any state it is put in, unlike the open-loop path of track_samcon,
// which falls apart under small perturbations (docs/SIM.md §5c).
//
// At the start of each window (reference frame t, current state s): `samples` candidate offsets δ_i to the balance
// expert's targets are drawn: δ_0 = 0 (the expert alone), δ_1 = δ_prev (the offset chosen for the previous window),
// δ_i = carry δ_prev + N(0, sigma² I) (rad per hinge) for i >= 2. Each candidate is simulated from s for
// window × horizon control steps with its offset held (the expert's feedback running underneath), scored by
//   cost_i = Σ_steps mean_j |p_sim,j - p_ref,j|²       (world positions of the 21 tracked bodies)
// and dropped if a body drifts fail_distance from the reference on any step. The cheapest survivor (else the
// cheapest overall; ties by index) is applied to the tracked body for the first `window` steps only, with
// Gaussian noise of std target_noise (rad) added to every target it applies (robustness: the candidates are
// simulated without it). Then the next window is planned from where the body now is. Once the tracked body has
// failed (a body fail_distance from the reference), planning stops and the expert alone finishes the clip.
// Deterministic for a seed: offsets and noise are drawn on one thread in order, candidates are simulated in
// parallel (OpenMP, t2m::get_num_threads()) from the saved state, so the result does not depend on the threads.
// With temperature > 0 the applied offset is the survivors' cost-weighted mean instead (checked by one more
// simulation; the cheapest survivor when the mean fails): the argmin of a random search changes by about sigma
// from one window to the next, which a student cannot imitate (docs/BFM.md, session 23).
// Cost per second of motion: samples × window × horizon × 10 control steps (128 × 15: ~6 s on 2 threads).
// DAgger (docs/BFM.md, session 25): with a BodyDriver, another controller (a student policy) drives the tracked
// body in a share driver_share of the windows (drawn per window from the seed, except at shares 0 and 1: share 0
// is the run without a driver, bit for bit) and the planner's choice in the rest, while the planner still plans
// every window from the body's state: res.offset is then the planner's answer (the label) in the states the driver
// leads the body into, res.ctrl what was applied.
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "sim/balance_tracker.h"
#include "sim/pd_tracker.h"

namespace t2m::sim {

struct SamconMpcOptions {
  int samples = 128;          // candidates per window
  int window = 3;             // control steps each chosen offset is applied (0.1 s)
  int horizon = 5;            // look-ahead in windows (each candidate runs window × horizon steps)
  double sigma = 0.15;        // rad, std of the per-hinge offset around carry × the previous offset
  double carry = 0.5;         // how much of the previous window's offset new candidates start from, in [0, 1]
  double target_noise = 0.0;  // rad, noise on every target applied to the tracked body
  double temperature = 0.0;   // 0: apply the cheapest survivor; > 0: apply the cost-weighted mean of the survivors'
                              // offsets, w_i = exp(-(cost_i - cost_min) / (temperature * cost_min)) (MPPI-style;
                              // smoother, learnable offsets), when that mean survives its own simulation (else
                              // the cheapest)
  // A learnable teacher (docs/BFM.md, session 24): among the offsets that work, prefer small and persistent ones,
  //   cost_i += size_cost · mean_k δ_ik² + change_cost · mean_k (δ_ik - δ_prev,k)²     (k over the offset hinges)
  // (m² per rad², the scale of the tracking cost's sum of squared body errors), and search on fewer hinges.
  double size_cost = 0.0;
  double change_cost = 0.0;
  std::vector<int> hinges;    // the actuators that get offsets (others run the expert alone); empty: all
  uint64_t seed = 1;
  BalanceOptions balance;     // the feedback expert underneath (action_noise is ignored)
  double driver_share = 1.0;  // with a BodyDriver: the share of windows it drives, in [0, 1]
};

// A controller for the tracked body: the actuator targets [nu] for the control step that moves `body` towards
// reference frame t (called once per step, on the calling thread, in order).
using BodyDriver = std::function<void(const Env& body, int t, double* ctrl)>;

// The actuators of the trunk and the legs (Spine, Chest, UpperLeg, LowerLeg, Foot, Toes; 30 of our humanoid's 60):
// where an offset changes balance and stepping; the arms, neck and head follow the expert.
std::vector<int> lower_body_actuators(const Humanoid& h);

struct SamconMpcResult {
  PdResult track;              // the tracked body, scored like track_pd (track.simulated: qpos / qvel per frame)
  int frames_planned = 0;      // reference frames reached while planning (before the first failure)
  std::vector<double> offset;  // [frames - 1, nu] the offset chosen for each control step (rad; 0 after a failure)
  std::vector<double> ctrl;    // [frames - 1, nu] the actuator targets applied (expert + offset + noise, clamped)
};

// Errors (t2m::Error): a reference that does not match the humanoid; samples < 1, window < 1, horizon < 1,
// sigma, target_noise, temperature, size_cost or change_cost < 0 or not finite, carry or driver_share outside
// [0, 1], a hinge index outside [0, nu) or repeated, a driver's non-finite target.
SamconMpcResult track_samcon_mpc(const std::shared_ptr<const Humanoid>& h, const QposTrajectory& ref,
                                 const SamconMpcOptions& opt = {}, const PdOptions& pd = {},
                                 const BodyDriver& driver = {});

}  // namespace t2m::sim
