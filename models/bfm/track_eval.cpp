// track_eval.cpp — BFM rollouts in lockstep, the PD baseline and the action KL (see track_eval.h).
#include "models/bfm/track_eval.h"


#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <string>

#include "autograd/no_grad.h"
#include "sim/env.h"

namespace t2m::bfm {

void check_tracking_refs(const FbAgent* agent, const sim::Humanoid& h, const RefMotions& refs) {
  if (refs.clips() == 0) throw Error("track eval: no reference clips");
  if (refs.nq != h.model()->nq || refs.nv != h.model()->nv)
    throw Error("track eval: reference motions of another model (nq " + std::to_string(refs.nq) + ")");
  if (agent && (agent->config().obs_dim != refs.obs_dim || agent->config().action_dim != h.model()->nu))
    throw Error("track eval: the agent's obs/action dims (" + std::to_string(agent->config().obs_dim) + ", " +
                std::to_string(agent->config().action_dim) + ") do not match the humanoid's (" +
                std::to_string(refs.obs_dim) + ", " + std::to_string(h.model()->nu) + ")");
}
Tensor clip_states(const RefMotions& refs, int c) {
  const int T = refs.frames(c), D = refs.obs_dim;
  Tensor s = Tensor::empty({T, D});
  std::memcpy(s.data<float>(), refs.obs_at(c, 0), sizeof(float) * T * D);
  return s;
}

std::vector<sim::PdResult> track_bfm(FbAgent& agent, std::shared_ptr<const sim::Humanoid> h, const RefMotions& refs,
                                     const sim::PdOptions& opt, int window, const TrackLatentMap& map,
                                     TrackStart start) {
  check_tracking_refs(&agent, *h, refs);
  ag::NoGradGuard ng;
  const int N = refs.clips(), D = refs.obs_dim, A = h->model()->nu, d = agent.config().z_dim;
  std::vector<Tensor> z(N);  // [T-1, d] per clip
  if (window < 0) throw Error("track_bfm: window must be >= 0 (0 = the agent's track_window), got " +
                              std::to_string(window));
  const int L = window > 0 ? window : agent.config().track_window;
  for (int c = 0; c < N; ++c) {
    z[c] = agent.infer_tracking_z(clip_states(refs, c), L).contiguous();
    if (!map) continue;
    Tensor m = map(z[c]).contiguous();
    if (m.shape() != z[c].shape() || m.dtype() != z[c].dtype())
      throw Error("track_bfm: the latent map turned " + shape_str(z[c].shape()) + " into " + shape_str(m.shape()) +
                  " (clip " + refs.names[c] + ")");
    z[c] = std::move(m);
  }
  std::vector<std::unique_ptr<sim::Env>> envs;
  std::vector<sim::TrackingScorer> score;
  score.reserve(N);
  std::vector<sim::QposTrajectory> traj(N);
  for (int c = 0; c < N; ++c) traj[c] = refs.trajectory(c);
  std::vector<float> obs((size_t)N * D);
  for (int c = 0; c < N; ++c) {
    envs.push_back(std::make_unique<sim::Env>(h));
    if (start == TrackStart::standing)
      envs[c]->reset(nullptr, nullptr, obs.data() + (size_t)c * D);  // the model's defaults: qpos0 at rest
    else
      envs[c]->reset(traj[c].qpos.data(), traj[c].qvel.data(), obs.data() + (size_t)c * D);
    score.emplace_back(*h, traj[c], opt);
    score[c].add_frame(*envs[c]);
  }
  int Tmax = 0;
  for (int c = 0; c < N; ++c) Tmax = std::max(Tmax, refs.frames(c));
  Tensor action;
  Generator unused(0);
  for (int t = 0; t + 1 < Tmax; ++t) {
    std::vector<int> act;  // clips still running at step t -> t+1
    for (int c = 0; c < N; ++c)
      if (t + 1 < refs.frames(c)) act.push_back(c);
    const int64_t M = (int64_t)act.size();
    Tensor o = Tensor::empty({M, D}), zz = Tensor::empty({M, d});
    for (int64_t i = 0; i < M; ++i) {
      std::memcpy(o.data<float>() + i * D, obs.data() + (size_t)act[i] * D, sizeof(float) * D);
      std::memcpy(zz.data<float>() + i * d, z[act[i]].data<float>() + (int64_t)t * d, sizeof(float) * d);
    }
    const Tensor a = agent.actor_mean(o, zz).contiguous();
    if (a.shape() != Shape{M, A}) throw Error("track eval: actor returned " + shape_str(a.shape()));
#pragma omp parallel for schedule(dynamic)
    for (int64_t i = 0; i < M; ++i) {
      const int c = act[i];
      envs[c]->step(a.data<float>() + i * A, obs.data() + (size_t)c * D);
      score[c].add_frame(*envs[c]);
    }
  }
  std::vector<sim::PdResult> out;
  for (int c = 0; c < N; ++c) out.push_back(score[c].result());
  return out;
}

namespace {
// One controller over every clip (OpenMP over clips); `who` names it in errors.
template <class Track>
std::vector<sim::PdResult> track_all(std::shared_ptr<const sim::Humanoid> h, const RefMotions& refs, const char* who,
                                     Track track) {
  check_tracking_refs(nullptr, *h, refs);
  const int N = refs.clips();
  std::vector<sim::PdResult> out(N);
  std::vector<std::string> err(N);
#pragma omp parallel for schedule(dynamic)
  for (int c = 0; c < N; ++c) {
    try {
      sim::Env env(h);
      out[c] = track(env, refs.trajectory(c));
      out[c].simulated = {};
    } catch (const std::exception& e) {
      err[c] = e.what();
    }
  }
  for (int c = 0; c < N; ++c)
    if (!err[c].empty()) throw Error(std::string("track eval: ") + who + " on " + refs.names[c] + ": " + err[c]);
  return out;
}
}  // namespace

std::vector<sim::PdResult> track_pd_all(std::shared_ptr<const sim::Humanoid> h, const RefMotions& refs,
                                        const sim::PdOptions& opt) {
  return track_all(h, refs, "PD", [&](sim::Env& env, const sim::QposTrajectory& q) { return sim::track_pd(env, q, opt); });
}

std::vector<sim::PdResult> track_balance_all(std::shared_ptr<const sim::Humanoid> h, const RefMotions& refs,
                                             const sim::BalanceOptions& bal, const sim::PdOptions& opt) {
  return track_all(h, refs, "balance expert",
                   [&](sim::Env& env, const sim::QposTrajectory& q) { return sim::track_balance(env, q, bal, opt); });
}

std::vector<int> holdable_start_clips(std::shared_ptr<const sim::Humanoid> h, const RefMotions& refs, int frames,
                                      const sim::BalanceOptions& bal) {
  check_tracking_refs(nullptr, *h, refs);
  if (frames < 2) throw Error("holdable_start_clips: frames must be >= 2, got " + std::to_string(frames));
  const int N = refs.clips();
  std::vector<char> ok(N, 0);
#pragma omp parallel for schedule(dynamic)
  for (int c = 0; c < N; ++c) {
    sim::Env env(h);
    ok[c] = sim::track_balance(env, still_trajectory(refs.qpos_at(c, 0), refs.nq, refs.nv, frames), bal).success;
  }
  std::vector<int> out;
  for (int c = 0; c < N; ++c)
    if (ok[c]) out.push_back(c);
  return out;
}

std::vector<double> expert_imitation_rms(FbAgent& agent, std::shared_ptr<const sim::Humanoid> h, const RefMotions& refs,
                                         const sim::BalanceOptions& bal) {
  check_tracking_refs(&agent, *h, refs);
  ag::NoGradGuard ng;
  const int A = h->model()->nu;
  std::vector<double> se((size_t)A, 0.0);
  int64_t n = 0;
  sim::Env env(h);
  std::vector<double> ctrl((size_t)A);
  for (int c = 0; c < refs.clips(); ++c) {
    const int T = refs.frames(c);
    const Tensor s = clip_states(refs, c);
    const Tensor mu = agent.actor_mean(s.narrow(0, 0, T - 1).contiguous(), agent.infer_tracking_z(s)).contiguous();
    const sim::QposTrajectory q = refs.trajectory(c);
    const sim::BalanceReference bref = sim::balance_reference(*h, q);
    for (int t = 0; t + 1 < T; ++t, ++n) {
      env.reset(refs.qpos_at(c, t), refs.qvel_at(c, t), nullptr);
      sim::balance_targets(env, bref.frame(q, t + 1), bal, ctrl.data());
      for (int k = 0; k < A; ++k) {
        const double e = mu.data<float>()[(int64_t)t * A + k] - std::clamp(env.ctrl_to_action(k, ctrl[k]), -1.0, 1.0);
        se[k] += e * e;
      }
    }
  }
  for (double& x : se) x = std::sqrt(x / std::max<int64_t>(n, 1));
  return se;
}

std::vector<double> window_action_kl(FbAgent& agent, const RefMotions& refs, int L_hat) {
  ag::NoGradGuard ng;
  std::vector<double> kl;
  for (int c = 0; c < refs.clips(); ++c) {
    const Tensor s = clip_states(refs, c);
    const Tensor z = agent.infer_tracking_z(s);
    const Tensor zh = agent.infer_tracking_z(s, L_hat);
    kl.push_back(agent.action_kl(s.narrow(0, 0, s.size(0) - 1), zh, z));  // Text2BFM Eq 21
  }
  return kl;
}

namespace {
// The summary fields over the clips `r` points at.
nlohmann::json summarize(const std::vector<const sim::PdResult*>& r) {
  double succ = 0, fell = 0, mpjpe = 0, drift = 0, frac = 0;
  for (const sim::PdResult* x : r) {
    succ += x->success, fell += x->fell, mpjpe += x->mpjpe_m, drift += x->root_drift_m;
    frac += x->frames ? (double)x->frames_ok / x->frames : 0.0;
  }
  const double n = std::max<size_t>(r.size(), 1);
  return {{"clips", r.size()},       {"success_rate", succ / n}, {"fall_rate", fell / n},
          {"mpjpe_m", mpjpe / n},    {"root_drift_m", drift / n}, {"mean_fraction_of_frames_tracked", frac / n}};
}
}  // namespace

nlohmann::json summarize_tracking(const std::vector<sim::PdResult>& r) {
  std::vector<const sim::PdResult*> all;
  for (const auto& x : r) all.push_back(&x);
  return summarize(all);
}

nlohmann::json summarize_tracking_by_group(const std::vector<sim::PdResult>& r, const std::vector<std::string>& group) {
  if (group.size() != r.size())
    throw Error("summarize_tracking_by_group: " + std::to_string(group.size()) + " group labels for " +
                std::to_string(r.size()) + " results");
  std::map<std::string, std::vector<const sim::PdResult*>> by;
  for (size_t c = 0; c < r.size(); ++c) by[group[c]].push_back(&r[c]);
  nlohmann::json out = nlohmann::json::object();
  for (const auto& [g, rs] : by) out[g] = summarize(rs);
  return out;
}

}  // namespace t2m::bfm
