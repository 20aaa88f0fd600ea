// collect.h — tracking episodes in parallel MuJoCo environments that fill a replay buffer:
//   seed data: a noisy expert tracker in the policy's [-1, 1] action space: the PD tracker (sim/pd_tracker's
//   control law) or PD plus stance-leg balance feedback (sim/balance_tracker, the default);
//   online data: the current policy pi(a | s, z_t) with z_t from Text2BFM Eq 2 on the reference (tracking).
//
//   TrackingCollector col(humanoid, refs, opt);
//   col.collect_expert(100000, seed_gen, buf);                      // 100k seed transitions
//   col.collect_policy(4096, encode_B, policy, gen, online_buf);     // one round of online collection
//
// Episodes: an env starts at a frame t0 drawn uniformly among all reference frames that have a successor (over
// all clips: longer clips are drawn more often), in the reference state (qpos[t0], qvel[t0]). Each control step
// tracks frame t -> t+1 and stores one transition (s_t, a_t, s_{t+1}, not_done = 1, clip, t). The episode ends
// (truncation, not a terminal: not_done stays 1) when the reference ends, after max_episode_steps, or once some
// body is >= fail_distance from the reference body (the tracking failure of sim/pd_tracker); the env then starts
// a new episode at once. A diverged physics step stores nothing and restarts the env.
// Calls are self-contained: every call starts fresh episodes in all envs and runs ceil(n / envs) steps per env
// (the last step's rows beyond n are dropped), so a training run that saves between calls resumes bit-identically.
// Determinism: start frames and expert noise come from the Generator passed in, drawn serially in env order; the
// physics runs in parallel (OpenMP over envs, sim::VecEnv) but each env is independent, so the buffer contents do
// not depend on the thread count.
// Expert action of actuator k at step t -> t+1: a_k = ctrl_to_action(target_k) + N(0, action_noise^2), clamped to
// [-1, 1], where target_k = clamp(qref[t+1, k] + (kd/kp) qdref[t+1, k]) (Expert::pd, the target sim/pd_tracker
// uses) or sim::balance_targets for reference frame t+1 (Expert::balance).
// Expert labels: into a buffer with expert labels (ReplayBuffer with_expert_labels) every row also gets the
// expert's noiseless action in the row's state s_t (for expert collection the action before the noise; for policy
// collection what the expert would have done where the policy went: DAgger's relabelling).
// Errors (t2m::Error "collect: ..."): envs < 1, max_episode_steps < 1, fail_distance <= 0, negative noise,
// n < 0, references of another model, a policy returning actions of the wrong shape or non-finite values.
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "models/bfm/ref_motions.h"
#include "models/bfm/replay_buffer.h"
#include "sim/balance_tracker.h"
#include "sim/env.h"
#include "tensor/rng.h"
#include "tensor/tensor.h"

namespace t2m::bfm {

enum class Expert { pd, balance };
Expert expert_from_string(const std::string& s);  // "pd" | "balance"; anything else: t2m::Error
const char* expert_name(Expert e);

struct CollectOptions {
  int envs = 16;                // parallel environments
  int max_episode_steps = 150;  // 5 s at 30 Hz
  double fail_distance = 0.5;   // m; sim::PdOptions' default
  double action_noise = 0.1;    // expert: std of the Gaussian added to the action; policy: passed to the policy
  Expert expert = Expert::balance;
  sim::BalanceOptions balance;  // Expert::balance gains
  int window = 8;               // L of Eq 2 (policy collection)
};

// Sets co.expert from a tracker name: "pd", "balance" or "balance-hips" (the balance expert with its root torque
// through the stance hips only: co.balance.torque_at_hips_only, which the other names clear); else t2m::Error.
void set_expert(CollectOptions& co, const std::string& name);

struct CollectStats {
  int64_t transitions = 0;       // rows added to the buffer
  int64_t episodes = 0;          // episodes that ended inside the call (ended by the reference end, length, fail)
  int64_t failed = 0;            // of those, ended by a tracking failure
  int64_t diverged = 0;          // physics divergences (no row stored)
  double seconds = 0;            // wall time of the call
  double mean_episode_steps() const { return episodes ? (double)ended_steps / episodes : 0.0; }
  int64_t ended_steps = 0;       // summed lengths of the ended episodes
};

// B(s) of a batch of states: [M, D] -> [M, d] (rows of norm sqrt(d)), e.g. FbAgent::embed_backward.
using EncodeFn = std::function<Tensor(const Tensor& states)>;
// Actions for a batch: obs [N, D], z [N, d] -> action [N, A] in [-1, 1]; noise_std and gen as in FbAgent::act.
using PolicyFn = std::function<void(const Tensor& obs, const Tensor& z, float noise_std, Generator& gen,
                                    Tensor& action)>;

// Text2BFM Eq 2 for n (clip, frame t) pairs of the references: z = Proj(1/H sum_{k<H} B(s_{t+1+k})),
// H = min(L, T-1-t) (t < T-1). Returns [n, d]. One encode call over all window states.
Tensor window_latents(const RefMotions& refs, const int64_t* clip, const int64_t* frame, int64_t n, int L,
                      const EncodeFn& encode);

class TrackingCollector {
 public:
  TrackingCollector(std::shared_ptr<const sim::Humanoid> h, const RefMotions& refs, CollectOptions opt = {});

  CollectStats collect_expert(int64_t n, Generator& gen, ReplayBuffer& buf);
  CollectStats collect_policy(int64_t n, const EncodeFn& encode, const PolicyFn& policy, Generator& gen,
                              ReplayBuffer& buf);
  const CollectOptions& options() const { return opt_; }

 private:
  struct EnvState {
    int clip = 0, frame = 0, steps = 0;
  };
  CollectStats run(int64_t n, Generator& gen, ReplayBuffer& buf, const EncodeFn* encode, const PolicyFn* policy);
  void start_episode(int e, Generator& gen);
  void expert_actions(Generator& gen);  // noiseless expert actions into labels_, plus noise into actions_
  void expert_labels();                 // labels_ [N, A]: the expert's (noiseless) action in every env's state

  std::shared_ptr<const sim::Humanoid> h_;
  const RefMotions& refs_;
  CollectOptions opt_;
  sim::VecEnv venv_;
  std::vector<int64_t> starts_;     // global frames with a successor
  std::vector<int> start_clip_;     // their clip
  std::vector<EnvState> st_;
  std::vector<float> obs_, next_obs_, actions_;  // [N, D], [N, D], [N, A]
  std::vector<double> ctrl_;       // [N, A]
  std::vector<float> labels_;      // [N, A]
  std::vector<sim::BalanceReference> balance_ref_;  // per clip (Expert::balance)
};

}  // namespace t2m::bfm
