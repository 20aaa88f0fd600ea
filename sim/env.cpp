// env.cpp — Env (model + workspace, control step = substeps physics steps) and VecEnv (OpenMP over envs).
#include "sim/env.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "sim/observation.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"

namespace t2m::sim {

Env::Env(std::shared_ptr<const Humanoid> h, EnvOptions opt) : h_(std::move(h)), model_(h_->model()), opt_(opt) {
  if (opt_.substeps < 1) throw Error("Env: substeps must be >= 1 (got " + std::to_string(opt_.substeps) + ")");
  if (!std::isfinite(opt_.assist_force)) throw Error("Env: assist_force is not finite");
  if (h_->tracked_bodies().empty()) throw Error("Env: the model has no bodies to observe");
  d_ = mj_makeData(model_);
  if (!d_) throw Error("Env: mj_makeData failed");
  obs_dim_ = observation_dim((int)h_->tracked_bodies().size());
  mj_forward(model_, d_);
}

Env::~Env() {
  if (d_) mj_deleteData(d_);
}

double Env::action_to_ctrl(int k, double a) const {
  a = std::clamp(a, -1.0, 1.0);
  if (!model_->actuator_ctrllimited[k]) return a;
  const double lo = model_->actuator_ctrlrange[2 * k], hi = model_->actuator_ctrlrange[2 * k + 1];
  return lo + 0.5 * (a + 1.0) * (hi - lo);
}

double Env::ctrl_to_action(int k, double c) const {
  if (!model_->actuator_ctrllimited[k]) return std::clamp(c, -1.0, 1.0);
  const double lo = model_->actuator_ctrlrange[2 * k], hi = model_->actuator_ctrlrange[2 * k + 1];
  return std::clamp(2.0 * (c - lo) / (hi - lo) - 1.0, -1.0, 1.0);
}

void Env::reset(const double* qpos, const double* qvel, float* obs_out) {
  mj_resetData(model_, d_);
  if (qpos) {
    for (int i = 0; i < model_->nq; ++i)
      if (!std::isfinite(qpos[i])) throw Error("Env::reset: qpos[" + std::to_string(i) + "] is not finite");
    mju_copy(d_->qpos, qpos, model_->nq);
  }
  if (qvel) {
    for (int i = 0; i < model_->nv; ++i)
      if (!std::isfinite(qvel[i])) throw Error("Env::reset: qvel[" + std::to_string(i) + "] is not finite");
    mju_copy(d_->qvel, qvel, model_->nv);
  }
  diverged_ = false;
  mj_forward(model_, d_);
  if (obs_out) observe(obs_out);
}

void Env::step(const float* action, float* obs_out) {
  for (int k = 0; k < model_->nu; ++k)
    if (!std::isfinite(action[k]))
      throw Error("Env::step: action[" + std::to_string(k) + "] = " + std::to_string(action[k]) +
                  " is not finite");
  for (int k = 0; k < model_->nu; ++k) d_->ctrl[k] = action_to_ctrl(k, action[k]);
  advance();
  if (obs_out) observe(obs_out);
}

void Env::step_targets(const double* ctrl, float* obs_out) {
  for (int k = 0; k < model_->nu; ++k)
    if (!std::isfinite(ctrl[k]))
      throw Error("Env::step_targets: ctrl[" + std::to_string(k) + "] is not finite");
  mju_copy(d_->ctrl, ctrl, model_->nu);
  advance();
  if (obs_out) observe(obs_out);
}

void Env::save_state(EnvState& s) const {
  s.time = d_->time;
  s.qpos.assign(d_->qpos, d_->qpos + model_->nq);
  s.qvel.assign(d_->qvel, d_->qvel + model_->nv);
  s.act.assign(d_->act, d_->act + model_->na);
  s.qacc_warmstart.assign(d_->qacc_warmstart, d_->qacc_warmstart + model_->nv);
  s.contact.assign(d_->contact, d_->contact + d_->ncon);
  s.diverged = diverged_;
}

void Env::restore_state(const EnvState& s) {
  if ((int)s.qpos.size() != model_->nq || (int)s.qvel.size() != model_->nv || (int)s.act.size() != model_->na ||
      (int)s.qacc_warmstart.size() != model_->nv || (int)s.contact.size() > model_->nconmax)
    throw Error("Env::restore_state: the state does not match this model (nq " + std::to_string(s.qpos.size()) +
                ", nv " + std::to_string(s.qvel.size()) + ", contacts " + std::to_string(s.contact.size()) + ")");
  d_->time = s.time;
  mju_copy(d_->qpos, s.qpos.data(), model_->nq);
  mju_copy(d_->qvel, s.qvel.data(), model_->nv);
  if (model_->na) mju_copy(d_->act, s.act.data(), model_->na);
  mju_copy(d_->qacc_warmstart, s.qacc_warmstart.data(), model_->nv);
  std::copy(s.contact.begin(), s.contact.end(), d_->contact);
  d_->ncon = (int)s.contact.size();
  diverged_ = s.diverged;
  // The derived quantities advance() leaves behind, from the restored state.
  mj_kinematics(model_, d_);
  mj_comPos(model_, d_);
  mj_comVel(model_, d_);
}

void Env::advance() {
  const int root = h_->tracked_bodies()[0];
  for (int s = 0; s < opt_.substeps; ++s) {
    if (opt_.assist_force != 0.0) d_->xfrc_applied[6 * root + 2] = opt_.assist_force;
    mj_step(model_, d_);
  }
  for (int i = 0; i < model_->nq; ++i)
    if (!std::isfinite(d_->qpos[i])) diverged_ = true;
  if (d_->warning[mjWARN_BADQACC].number > 0) diverged_ = true;
  // Make the derived quantities match the new state (mj_step leaves them at the start of the last step).
  mj_kinematics(model_, d_);
  mj_comPos(model_, d_);
  mj_comVel(model_, d_);
}

void Env::observe(float* obs_out) const {
  const auto& b = h_->tracked_bodies();
  compute_observation(model_, d_, b.data(), (int)b.size(), obs_out);
}

VecEnv::VecEnv(std::shared_ptr<const Humanoid> h, int n, EnvOptions opt) {
  if (n < 1) throw Error("VecEnv: need at least one env (got " + std::to_string(n) + ")");
  for (int i = 0; i < n; ++i) envs_.push_back(std::make_unique<Env>(h, opt));
}

void VecEnv::step(const float* actions, float* obs) {
  const int N = size(), A = action_dim(), D = obs_dim();
  for (int i = 0; i < N * A; ++i)
    if (!std::isfinite(actions[i]))
      throw Error("VecEnv::step: action[" + std::to_string(i / A) + ", " + std::to_string(i % A) +
                  "] is not finite");
  const int threads = std::max(1, std::min(N, get_num_threads()));  // the process-wide policy (tensor/parallel.h)
  // Dynamic, one env at a time: a standing env (many foot contacts) costs up to ~2x a flying one, and on a shared
  // machine one thread may be descheduled; a static split would make the whole step wait for the slowest half.
  // Results do not depend on the schedule (every env is independent and stepped by exactly one thread).
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (int i = 0; i < N; ++i) envs_[i]->step(actions + (size_t)i * A, obs ? obs + (size_t)i * D : nullptr);
}

}  // namespace t2m::sim
