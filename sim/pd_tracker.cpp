// pd_tracker.cpp — PD tracking of a reference trajectory with metrics (see pd_tracker.h).
#include "sim/pd_tracker.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "tensor/tensor.h"

namespace t2m::sim {

PdResult track_pd(Env& env, const QposTrajectory& ref, const PdOptions& opt) {
  const mjModel* m = env.model();
  const Humanoid& h = env.humanoid();
  if (!h.is_humanoid()) throw Error("track_pd: the env's model is not the t2m humanoid");
  check_tracking_reference(m, ref, "track_pd");
  const int T = ref.frames, nu = m->nu;
  TrackingScorer score(h, ref, opt);
  std::vector<double> ctrl(nu);
  env.reset(ref.qpos.data(), ref.qvel.data(), nullptr);
  for (int t = 0; t < T; ++t) {
    if (t > 0) {
      pd_target_angles(m, ref.qpos.data() + (size_t)t * m->nq, ref.qvel.data() + (size_t)t * m->nv,
                       opt.velocity_feedforward, ctrl.data());
      clamp_to_ctrlrange(m, ctrl.data());
      env.step_targets(ctrl.data(), nullptr);
    }
    score.add_frame(env);
  }
  return score.result();
}

void pd_target_angles(const mjModel* m, const double* qpos_ref, const double* qvel_ref, bool feedforward,
                      double* ctrl) {
  for (int k = 0; k < m->nu; ++k) {
    const int jid = m->actuator_trnid[2 * k], dof = m->jnt_dofadr[jid];
    const double kp = m->actuator_gainprm[mjNGAIN * k];
    const double ff = (feedforward && kp > 0) ? m->dof_damping[dof] / kp : 0.0;
    ctrl[k] = qpos_ref[m->jnt_qposadr[jid]] + ff * qvel_ref[dof];
  }
}

void check_tracking_reference(const mjModel* m, const QposTrajectory& ref, const char* who) {
  if (ref.nq != m->nq || ref.nv != m->nv || ref.qpos.size() != (size_t)ref.frames * m->nq ||
      ref.qvel.size() != (size_t)ref.frames * m->nv || ref.frames < 1)
    throw Error(std::string(who) + ": reference has " + std::to_string(ref.frames) + " frames, nq " +
                std::to_string(ref.nq) + ", nv " + std::to_string(ref.nv) + " (model nq " + std::to_string(m->nq) +
                ", nv " + std::to_string(m->nv) + ")");
}

void clamp_to_ctrlrange(const mjModel* m, double* ctrl) {
  for (int k = 0; k < m->nu; ++k)
    if (m->actuator_ctrllimited[k])
      ctrl[k] = std::clamp(ctrl[k], m->actuator_ctrlrange[2 * k], m->actuator_ctrlrange[2 * k + 1]);
}

TrackingScorer::TrackingScorer(const Humanoid& h, const QposTrajectory& ref, const PdOptions& opt)
    : h_(h), opt_(opt), T_(ref.frames) {
  if (!h.is_humanoid()) throw Error("TrackingScorer: the model is not the t2m humanoid");
  ref_pos_ = replay_joint_positions(h, ref);  // checks the reference sizes
  simulated_.fps = ref.fps, simulated_.nq = ref.nq, simulated_.nv = ref.nv;
  simulated_.qpos.reserve((size_t)T_ * ref.nq);
  simulated_.qvel.reserve((size_t)T_ * ref.nv);
}

void TrackingScorer::add_frame(const Env& env) {
  if (t_ >= T_) throw Error("TrackingScorer: frame " + std::to_string(t_) + " beyond the reference's " +
                            std::to_string(T_) + " frames");
  const int B = kNumJoints, t = t_;
  const mjData* d = env.data();
  const auto& bodies = h_.tracked_bodies();
  double frame_max = 0;
  for (int j = 0; j < B; ++j) {
    const double* p = d->xpos + 3 * bodies[j];
    const float* q = ref_pos_.data() + ((size_t)t * B + j) * 3;
    const double e = std::sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                               (p[2] - q[2]) * (p[2] - q[2]));
    frame_max = std::max(frame_max, e);
    if (t > 0) sum_ += e;
  }
  if (!std::isfinite(frame_max) || env.diverged()) frame_max = INFINITY;
  last_error_ = frame_max;
  max_error_ = std::max(max_error_, frame_max);
  if (frame_max >= opt_.fail_distance) failed_ = true;
  if (!failed_) frames_ok_ = t + 1;
  const double root_z = d->xpos[3 * bodies[0] + 2], ref_z = ref_pos_[(size_t)t * B * 3 + 2];
  if (root_z < opt_.fall_height && ref_z >= opt_.fall_height) fell_ = true;
  const double dx = d->xpos[3 * bodies[0]] - ref_pos_[(size_t)t * B * 3];
  const double dy = d->xpos[3 * bodies[0] + 1] - ref_pos_[(size_t)t * B * 3 + 1];
  drift_ = std::sqrt(dx * dx + dy * dy);  // kept for the last frame
  simulated_.qpos.insert(simulated_.qpos.end(), d->qpos, d->qpos + simulated_.nq);
  simulated_.qvel.insert(simulated_.qvel.end(), d->qvel, d->qvel + simulated_.nv);
  simulated_.frames = ++t_;
}

PdResult TrackingScorer::result() const {
  PdResult r;
  r.frames = t_;
  r.success = !failed_;
  r.fell = fell_;
  r.mpjpe_m = t_ > 1 ? sum_ / ((double)(t_ - 1) * kNumJoints) : 0.0;
  r.root_drift_m = drift_;
  r.max_error_m = max_error_;
  r.frames_ok = frames_ok_;
  r.simulated = simulated_;
  return r;
}

}  // namespace t2m::sim
