// env.h — the simulation environment: a read-only Humanoid (mjModel) plus one mutable mjData workspace per Env.
//
//   auto h = Humanoid::create();
//   Env env(h);                         // allocates the workspace once
//   env.reset(qpos, qvel, obs);         // qpos [nq], qvel [nv] (nullptr: model defaults / zero), obs [obs_dim()]
//   env.step(action, obs);              // action [action_dim()] in [-1, 1] -> obs after one control step
//
// A control step = `substeps` physics steps (default 15 x 1/450 s = 1/30 s) with the actuator controls held.
// Action mapping (per actuator with a ctrlrange [lo, hi]): ctrl = lo + (a + 1) / 2 (hi - lo), a clamped to
// [-1, 1]; for our humanoid that is the PD target angle of the hinge (a = 0 is the middle of the joint range).
// Actuators without a ctrlrange get ctrl = a. step_targets() sets ctrl directly (e.g. PD target angles, rad).
// Optional assist (off by default, disclose when used): a vertical force of `assist_force` N on the root body.
// step()/step_targets() allocate nothing. Errors: non-finite action / target -> t2m::Error naming the index;
// wrong-size vectors -> t2m::Error. If the physics diverges (non-finite qpos/qvel), diverged() turns true and the
// state is left as MuJoCo reset it; call reset().
//
// VecEnv: N independent Envs over one shared model, stepped in parallel with OpenMP (dynamic schedule, one Env
// per iteration; the result does not depend on the thread count or schedule).
#pragma once
#include <mujoco/mujoco.h>

#include <memory>
#include <vector>

#include "sim/humanoid.h"

namespace t2m::sim {

struct EnvOptions {
  int substeps = kSubsteps;
  double assist_force = 0.0;  // N, upward on the root body; 0 = no assist (the default and the baseline)
};

// A saved simulation state (Env::save_state / restore_state): everything the next control step reads — qpos, qvel,
// act, the solver's warm start, time, and the contacts of the last physics step (which the balance expert reads to
// find its stance legs). Restoring it and stepping gives bit for bit the steps the saved env would have taken.
struct EnvState {
  double time = 0;
  std::vector<double> qpos, qvel, act, qacc_warmstart;
  std::vector<mjContact> contact;
  bool diverged = false;
};

class Env {
 public:
  explicit Env(std::shared_ptr<const Humanoid> h, EnvOptions opt = {});
  ~Env();
  Env(const Env&) = delete;
  Env& operator=(const Env&) = delete;

  int obs_dim() const { return obs_dim_; }
  int action_dim() const { return model_->nu; }
  int nq() const { return model_->nq; }
  int nv() const { return model_->nv; }

  void reset(const double* qpos, const double* qvel, float* obs_out);
  void step(const float* action, float* obs_out);
  void step_targets(const double* ctrl, float* obs_out);  // ctrl [action_dim()] in actuator units
  void observe(float* obs_out) const;                     // the observation of the current state
  void save_state(EnvState& s) const;  // reuses s's buffers
  void restore_state(const EnvState& s);  // throws t2m::Error if s was saved from another model's sizes

  const mjModel* model() const { return model_; }
  const mjData* data() const { return d_; }
  const Humanoid& humanoid() const { return *h_; }
  bool diverged() const { return diverged_; }

  // Action in [-1, 1] <-> ctrl mapping for actuator k (see above).
  double action_to_ctrl(int k, double a) const;
  double ctrl_to_action(int k, double ctrl) const;

 private:
  void advance();
  std::shared_ptr<const Humanoid> h_;
  const mjModel* model_;
  mjData* d_ = nullptr;
  EnvOptions opt_;
  int obs_dim_ = 0;
  bool diverged_ = false;
};

class VecEnv {
 public:
  VecEnv(std::shared_ptr<const Humanoid> h, int n, EnvOptions opt = {});
  int size() const { return (int)envs_.size(); }
  Env& env(int i) { return *envs_.at(i); }
  int obs_dim() const { return envs_[0]->obs_dim(); }
  int action_dim() const { return envs_[0]->action_dim(); }
  // actions [N, action_dim], obs [N, obs_dim]. All actions are checked before any env steps.
  void step(const float* actions, float* obs);

 private:
  std::vector<std::unique_ptr<Env>> envs_;
};

}  // namespace t2m::sim
