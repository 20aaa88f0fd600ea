// balance_tracker.h — the PD tracker plus balance feedback through the stance legs (virtual model control):
// a hand-designed expert that keeps the humanoid up while it follows a reference, used as the behaviour the BFM
// imitates (models/bfm). The plain PD baseline (sim/pd_tracker.h) is unchanged and stays the baseline.
//
// Per control step t -> t+1, on top of the PD target of sim/pd_tracker (reference hinge angles + velocity
// feed-forward), a virtual wrench on the body is realised by the stance legs' hinges (Jacobian transpose, with the
// stance foot as the fixed base; Pratt et al. 2001 "virtual model control", Coros et al. 2010):
//   F = M (kp_c (c_ref - c) + kd_c (v_ref - v))           horizontal centre-of-mass feedback (clamped to max_force)
//   T = kp_o log(R_ref R^T) + kd_o (w_ref - w)             root (pelvis) orientation feedback, world frame
//   tau_i = -a_i . ((c - p_i) x F_leg + T_leg)              hinge i of a stance leg (hip, knee, ankle); axis a_i at p_i
//                                                           (T only at the hips with torque_at_hips_only)
//   target_i += clamp(tau_i / kp_i, +-max_offset)           position actuators: force = kp (target - q)
// (F, T) are split equally over the legs whose foot or toes touch the floor; no stance leg = plain PD.
// c, v: whole-body centre of mass and its velocity; R, w: root orientation and angular velocity (world).
// The controller is a function of (state, reference frame), so it can label any visited state (DAgger).
#pragma once
#include <cstdint>
#include <vector>

#include "sim/env.h"
#include "sim/pd_tracker.h"
#include "sim/retarget.h"

namespace t2m::sim {

struct BalanceOptions {
  // Defaults chosen on the val split (`t2m track-pd --split val --balance`, grid over the five gains).
  double com_kp = 100.0;     // 1/s^2 (times the body mass)
  double com_kd = 40.0;      // 1/s
  double root_kp = 300.0;    // N m / rad
  double root_kd = 30.0;     // N m s / rad
  double max_force = 600.0;  // N, horizontal virtual force
  double max_offset = 0.5;   // rad, per hinge target offset
  bool torque_at_hips_only = false;  // T through the stance hips only (SIMBICON-style); val 29.1 % vs 26.5 %, not
                                     // the default yet (the shipped BFM's teacher used false)
  // track_balance only: Gaussian noise of this std added to every target in the policy's [-1, 1] action units
  // (Env::ctrl_to_action) at every step, then clamped — how precisely a student must imitate the expert. Drawn
  // from std::mt19937_64(noise_seed), so a clip's result does not depend on threads.
  double action_noise = 0.0;
  uint64_t noise_seed = 0;
};

// One reference frame as the controller reads it (pointers into a trajectory and its BalanceReference).
struct BalanceFrame {
  const double* qpos;         // [nq]
  const double* qvel;         // [nv]
  const double* com;          // [3] whole-body centre of mass
  const double* com_vel;      // [3]
  const double* root_quat;    // [4] (w, x, y, z), world
  const double* root_angvel;  // [3] world frame
};

// The reference quantities the feedback needs, per frame of one reference trajectory.
struct BalanceReference {
  int frames = 0;
  std::vector<double> com;          // [T, 3]
  std::vector<double> com_vel;      // [T, 3] central differences
  std::vector<double> root_quat;    // [T, 4]
  std::vector<double> root_angvel;  // [T, 3]
  // Frame t of `ref` (the trajectory this was computed from), or with that frame's qpos / qvel given directly.
  // Throws t2m::Error on t out of range.
  BalanceFrame frame(const QposTrajectory& ref, int t) const;
  BalanceFrame frame(const double* qpos, const double* qvel, int t) const;
};
BalanceReference balance_reference(const Humanoid& h, const QposTrajectory& ref);

// PD + balance targets (actuator units, clamped to the ctrl ranges) for the step towards reference frame `f`, from
// the env's current state. ctrl [nu].
void balance_targets(const Env& env, const BalanceFrame& f, const BalanceOptions& opt, double* ctrl);

// Whole clip from the reference start state, scored like track_pd.
PdResult track_balance(Env& env, const QposTrajectory& ref, const BalanceOptions& opt = {},
                       const PdOptions& pd = {});

}  // namespace t2m::sim
