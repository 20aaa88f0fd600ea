// pd_tracker.h — the PD tracking baseline: follow a reference qpos trajectory with the humanoid's position
// actuators, no learning, and measure how well the simulated body follows the reference.
//
// Control at 30 Hz: for the step t -> t+1 the actuator target of hinge k is
//     target_k = qref[t+1, k] + (kd_k / kp_k) qdref[t+1, k]          (velocity feed-forward, optional)
// which makes kp (target - q) - kd qd = kp (qref - q) + kd (qdref - qd): a PD law on position and velocity
// (kd = joint damping, kp = actuator gain). Targets are clamped to the actuator range. The root is not actuated.
// Assist: EnvOptions::assist_force (vertical force on the root, N); 0 by default and reported in the result.
// The episode starts from the reference state (qpos[0], qvel[0]) and always runs the whole clip.
// Metrics (positions = the 21 body origins = joint positions):
//   per-frame error e_t = max_j |p_sim - p_ref|;  success = e_t < fail_distance (0.5 m) on every frame;
//   mpjpe = mean over frames t >= 1 and joints of |p_sim - p_ref|;  root_drift = horizontal root distance at the
//   last frame;  fell = the root drops below fall_height (0.5 m) on some frame where the reference root is above it;
//   frames_ok = frames before the first e_t >= fail_distance.
// Errors: trajectory sizes not matching the env's model or a model that is not our humanoid -> t2m::Error.
#pragma once
#include <vector>

#include "sim/env.h"
#include "sim/retarget.h"

namespace t2m::sim {

struct PdOptions {
  bool velocity_feedforward = true;
  double fail_distance = 0.5;  // m
  double fall_height = 0.5;    // m
};

struct PdResult {
  int frames = 0;
  bool success = false;
  bool fell = false;
  double mpjpe_m = 0;
  double root_drift_m = 0;
  double max_error_m = 0;
  int frames_ok = 0;
  double assist_force = 0;
  QposTrajectory simulated;  // the simulated qpos / qvel per frame (frame 0 = the reference start)
};

PdResult track_pd(Env& env, const QposTrajectory& ref, const PdOptions& opt = {});

// The control law above for the step towards one reference frame (qpos_ref [nq], qvel_ref [nv]), shared by every
// tracker built on it (sim/balance_tracker, models/bfm/collect): ctrl[k] = qref_k + (kd_k / kp_k) qdref_k (without
// the second term when !feedforward), NOT clamped; clamp_to_ctrlrange clamps ctrl [nu] to the actuator ranges.
void pd_target_angles(const mjModel* m, const double* qpos_ref, const double* qvel_ref, bool feedforward,
                      double* ctrl);
void clamp_to_ctrlrange(const mjModel* m, double* ctrl);
// Throws t2m::Error ("WHO: reference has ...") unless ref has >= 1 frame and qpos / qvel sizes of the model.
void check_tracking_reference(const mjModel* m, const QposTrajectory& ref, const char* who);

// The search planners' tracking cost of one frame (sim/samcon*.h, models/bfm/latent_search.h; defined in
// samcon.cpp): mean_j |p_sim,j - p_ref,j|² over the tracked bodies against ref_pos [J, 3] (one reference frame);
// the largest |p_sim,j - p_ref,j| in *worst.
double tracking_frame_cost(const mjData* d, const std::vector<int>& bodies, const float* ref_pos, double* worst);

// The metric code of track_pd for any controller (the BFM tracker and SAMCON use it too): after the env holds the
// simulated state of frame t (t = 0, 1, ... in order; frame 0 = the start state), call add_frame(env), which also
// records that state; result() gives the metric fields of a PdResult and the recorded trajectory (frames = frames
// added; assist_force left empty). Throws t2m::Error on a reference that does not match the humanoid, or on more
// frames than the reference has.
class TrackingScorer {
 public:
  TrackingScorer(const Humanoid& h, const QposTrajectory& ref, const PdOptions& opt = {});
  void add_frame(const Env& env);
  PdResult result() const;
  int frames_added() const { return t_; }
  double last_frame_error() const { return last_error_; }  // max_j |p_sim - p_ref| of the last frame (m)

 private:
  const Humanoid& h_;
  PdOptions opt_;
  int T_;
  std::vector<float> ref_pos_;  // [T, 21, 3]
  QposTrajectory simulated_;    // the states added so far
  int t_ = 0, frames_ok_ = 0;
  double sum_ = 0, max_error_ = 0, drift_ = 0, last_error_ = 0;
  bool failed_ = false, fell_ = false;
};

}  // namespace t2m::sim
