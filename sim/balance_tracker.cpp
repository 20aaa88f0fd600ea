// balance_tracker.cpp — PD tracking plus stance-leg virtual-model balance feedback (see balance_tracker.h).
#include "sim/balance_tracker.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <utility>

#include "sim/skeleton.h"
#include "tensor/tensor.h"

namespace t2m::sim {
namespace {

// Whole-body centre-of-mass velocity from cvel ([angular; linear] at the subtree com of each body's root); returns
// the total mass it weighted by.
double com_velocity(const mjModel* m, const mjData* d, double v[3]) {
  v[0] = v[1] = v[2] = 0;
  double mass = 0;
  for (int b = 1; b < m->nbody; ++b) {
    const double* cv = d->cvel + 6 * b;
    const double* c0 = d->subtree_com + 3 * m->body_rootid[b];
    const double r[3] = {d->xipos[3 * b] - c0[0], d->xipos[3 * b + 1] - c0[1], d->xipos[3 * b + 2] - c0[2]};
    double w_x_r[3];
    mju_cross(w_x_r, cv, r);
    for (int i = 0; i < 3; ++i) v[i] += m->body_mass[b] * (cv[3 + i] + w_x_r[i]);
    mass += m->body_mass[b];
  }
  for (int i = 0; i < 3; ++i) v[i] /= mass;
  return mass;
}

// 0 = left leg, 1 = right leg, -1 = not a foot / toes body.
int stance_leg_of(const Humanoid& h, int body) {
  const auto& tb = h.tracked_bodies();
  if (body == tb[kFootL] || body == tb[kToesL]) return 0;
  if (body == tb[kFootR] || body == tb[kToesR]) return 1;
  return -1;
}

}  // namespace

BalanceReference balance_reference(const Humanoid& h, const QposTrajectory& ref) {
  const mjModel* m = h.model();
  check_tracking_reference(m, ref, "balance_reference");
  if (!h.is_humanoid()) throw Error("balance_reference: the model is not the t2m humanoid");
  const int T = ref.frames, root = h.tracked_bodies()[0];
  BalanceReference r;
  r.frames = T;
  r.com.resize((size_t)T * 3);
  r.com_vel.resize((size_t)T * 3);
  r.root_quat.resize((size_t)T * 4);
  r.root_angvel.resize((size_t)T * 3);
  mjData* d = mj_makeData(m);
  for (int t = 0; t < T; ++t) {
    mju_copy(d->qpos, ref.qpos.data() + (size_t)t * m->nq, m->nq);
    mj_kinematics(m, d);
    mj_comPos(m, d);
    mju_copy(r.com.data() + 3 * t, d->subtree_com + 3 * root, 3);
    mju_copy(r.root_quat.data() + 4 * t, d->xquat + 4 * root, 4);
    // free-joint angular velocity is in the body frame: rotate it to the world
    const double* w_local = ref.qvel.data() + (size_t)t * m->nv + h.root_dof() + 3;
    mju_rotVecMat(r.root_angvel.data() + 3 * t, w_local, d->xmat + 9 * root);
  }
  mj_deleteData(d);
  const double fps = ref.fps;
  for (int t = 0; t < T; ++t) {
    const int a = std::max(t - 1, 0), b = std::min(t + 1, T - 1);
    for (int i = 0; i < 3; ++i)
      r.com_vel[3 * t + i] = b > a ? (r.com[3 * b + i] - r.com[3 * a + i]) * fps / (b - a) : 0.0;
  }
  return r;
}

BalanceFrame BalanceReference::frame(const double* qpos, const double* qvel, int t) const {
  if (t < 0 || t >= frames)
    throw Error("BalanceReference::frame: frame " + std::to_string(t) + " of a " + std::to_string(frames) +
                "-frame reference");
  return {qpos, qvel, com.data() + 3 * t, com_vel.data() + 3 * t, root_quat.data() + 4 * t, root_angvel.data() + 3 * t};
}

BalanceFrame BalanceReference::frame(const QposTrajectory& ref, int t) const {
  if (ref.frames != frames)
    throw Error("BalanceReference::frame: a " + std::to_string(ref.frames) + "-frame trajectory for a " +
                std::to_string(frames) + "-frame reference");
  return frame(ref.qpos.data() + (size_t)t * ref.nq, ref.qvel.data() + (size_t)t * ref.nv, t);
}

void balance_targets(const Env& env, const BalanceFrame& f, const BalanceOptions& opt, double* ctrl) {
  const mjModel* m = env.model();
  const mjData* d = env.data();
  const Humanoid& h = env.humanoid();
  // PD part: the reference angle plus velocity feed-forward (sim/pd_tracker's law), clamped at the end.
  pd_target_angles(m, f.qpos, f.qvel, /*feedforward=*/true, ctrl);
  // Stance legs from the contacts.
  bool stance[2] = {false, false};
  for (int i = 0; i < d->ncon; ++i) {
    for (int g : {d->contact[i].geom1, d->contact[i].geom2}) {
      const int leg = stance_leg_of(h, m->geom_bodyid[g]);
      if (leg >= 0) stance[leg] = true;
    }
  }
  const int n_stance = (int)stance[0] + (int)stance[1];
  if (n_stance > 0) {
    const int root = h.tracked_bodies()[0];
    const double* c = d->subtree_com + 3 * root;
    double v[3];
    const double mass = com_velocity(m, d, v);
    // Virtual force on the centre of mass (horizontal).
    double F[3] = {0, 0, 0};
    for (int i = 0; i < 2; ++i)
      F[i] = mass * (opt.com_kp * (f.com[i] - c[i]) + opt.com_kd * (f.com_vel[i] - v[i]));
    const double fn = std::hypot(F[0], F[1]);
    if (fn > opt.max_force) F[0] *= opt.max_force / fn, F[1] *= opt.max_force / fn;
    // Virtual torque on the root: orientation error log(R_ref R^T) and angular-velocity error (world).
    double qinv[4], qerr[4], e[3];
    mju_negQuat(qinv, d->xquat + 4 * root);
    mju_mulQuat(qerr, f.root_quat, qinv);
    if (qerr[0] < 0)
      for (double& x : qerr) x = -x;
    mju_quat2Vel(e, qerr, 1.0);
    const double* w = d->cvel + 6 * root;  // angular part, world
    double T[3];
    for (int i = 0; i < 3; ++i)
      T[i] = opt.root_kp * e[i] + opt.root_kd * (f.root_angvel[i] - w[i]);
    for (int i = 0; i < 3; ++i) F[i] /= n_stance, T[i] /= n_stance;
    // Jacobian transpose over each stance leg's hinges (hip, knee, ankle bodies).
    const auto& tb = h.tracked_bodies();
    const int legs[2][3] = {{kUpperLegL, kLowerLegL, kFootL}, {kUpperLegR, kLowerLegR, kFootR}};
    for (int leg = 0; leg < 2; ++leg) {
      if (!stance[leg]) continue;
      for (int j : legs[leg]) {
        const int b = tb[j];
        for (int jn = m->body_jntadr[b]; jn < m->body_jntadr[b] + m->body_jntnum[b]; ++jn) {
          const double* a = d->xaxis + 3 * jn;
          const double* p = d->xanchor + 3 * jn;
          const double r[3] = {c[0] - p[0], c[1] - p[1], c[2] - p[2]};
          double rxF[3];
          mju_cross(rxF, r, F);
          const double st = opt.torque_at_hips_only && j != kUpperLegL && j != kUpperLegR ? 0.0 : 1.0;
          const double tau =
              -(a[0] * (rxF[0] + st * T[0]) + a[1] * (rxF[1] + st * T[1]) + a[2] * (rxF[2] + st * T[2]));
          // the actuator of this hinge: hinges and actuators share the order (k = 3 (j - 1) + i)
          const int k = 3 * (j - 1) + (jn - m->body_jntadr[b]);
          const double kp = m->actuator_gainprm[mjNGAIN * k];
          if (kp > 0) ctrl[k] += std::clamp(tau / kp, -opt.max_offset, opt.max_offset);
        }
      }
    }
  }
  clamp_to_ctrlrange(m, ctrl);
}

PdResult track_balance(Env& env, const QposTrajectory& ref, const BalanceOptions& opt, const PdOptions& pd) {
  const mjModel* m = env.model();
  const Humanoid& h = env.humanoid();
  if (!h.is_humanoid()) throw Error("track_balance: the env's model is not the t2m humanoid");
  check_tracking_reference(m, ref, "track_balance");
  const BalanceReference bref = balance_reference(h, ref);
  TrackingScorer score(h, ref, pd);
  if (!(opt.action_noise >= 0)) throw Error("track_balance: action_noise must be >= 0");
  std::vector<double> ctrl(m->nu);
  std::mt19937_64 rng(opt.noise_seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  env.reset(ref.qpos.data(), ref.qvel.data(), nullptr);
  score.add_frame(env);
  for (int t = 1; t < ref.frames; ++t) {
    balance_targets(env, bref.frame(ref, t), opt, ctrl.data());
    if (opt.action_noise > 0)
      for (int k = 0; k < m->nu; ++k)
        ctrl[k] = env.action_to_ctrl(k, std::clamp(env.ctrl_to_action(k, ctrl[k]) + opt.action_noise * noise(rng), -1.0, 1.0));
    env.step_targets(ctrl.data(), nullptr);
    score.add_frame(env);
  }
  return score.result();
}

}  // namespace t2m::sim
