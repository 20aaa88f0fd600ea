// latent_search.cpp — the window planner over z of latent_search.h: candidates stepped in lockstep, the policy run
// on one batch per control step, the physics in parallel.
#include "models/bfm/latent_search.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <tuple>

#include "autograd/no_grad.h"
#include "models/bfm/track_eval.h"
#include "sim/align_start.h"
#include "sim/env.h"

namespace t2m::bfm {
void check_search_options(const LatentSearchOptions& o) {
  if (o.samples < 1 || o.window < 1 || o.horizon < 1 || !(o.sigma >= 0) || !std::isfinite(o.sigma) ||
      !(o.carry >= 0 && o.carry <= 1) || o.elites < 1 || o.elites > o.samples || !(o.action_noise >= 0) ||
      !std::isfinite(o.action_noise) || o.transition < 0 || !(o.transition_fail_distance > 0) ||
      !std::isfinite(o.transition_fail_distance))
    throw Error("track_bfm_search: bad options (samples " + std::to_string(o.samples) + ", window " +
                std::to_string(o.window) + ", horizon " + std::to_string(o.horizon) + ", sigma " +
                std::to_string(o.sigma) + ", carry " + std::to_string(o.carry) + ", elites " +
                std::to_string(o.elites) + ", action noise " + std::to_string(o.action_noise) + ", transition " +
                std::to_string(o.transition) + ", transition fail distance " +
                std::to_string(o.transition_fail_distance) +
                "): need samples, window, horizon >= 1, finite sigma >= 0, carry in [0, 1], elites in [1, samples],"
                " finite action noise >= 0, transition >= 0, finite transition fail distance > 0");
}

namespace {

// z' = sqrt(d) (z + δ) / |z + δ| [d]; z itself when δ = 0 (bit for bit the latent of plain tracking).
void offset_latent(const float* z, const double* delta, int d, float* out) {
  if (std::all_of(delta, delta + d, [](double v) { return v == 0.0; })) {
    std::copy_n(z, d, out);
    return;
  }
  double n2 = 0;
  for (int k = 0; k < d; ++k) {
    out[k] = (float)((double)z[k] + delta[k]);
    n2 += (double)out[k] * out[k];
  }
  const float s = n2 > 0 ? (float)(std::sqrt((double)d / n2)) : 1.0f;
  for (int k = 0; k < d; ++k) out[k] *= s;
}

// sim::tracking_frame_cost of the env's frame; *worst = max(*worst, the frame's largest body error), infinite on
// divergence or once that error reaches the frame's fail distance (the candidate is dropped).
double candidate_frame_cost(const sim::Env& env, const std::vector<int>& bodies, const float* ref, double fail,
                            double* worst) {
  double w = 0;
  const double cost = sim::tracking_frame_cost(env.data(), bodies, ref, &w);
  *worst = env.diverged() || !(w < fail) ? INFINITY : std::max(*worst, w);
  return cost;
}

// The applied offset: the best candidate's (survivors, worst finite, first; then the cost, then the index), or with
// elites K > 1 the mean of the K best in that order (a NaN cost ranks last). order [S] is scratch.
void choose_offset(const std::vector<double>& delta, const std::vector<double>& cost, const std::vector<double>& worst,
                   int elites, int d, std::vector<int>& order, std::vector<double>& out) {
  const auto survives = [&](int i) { return std::isfinite(worst[i]); };
  if (elites == 1) {
    int best = 0;
    for (int i = 1; i < (int)cost.size(); ++i)
      if (survives(i) != survives(best) ? survives(i) : cost[i] < cost[best]) best = i;
    std::copy_n(delta.begin() + (size_t)best * d, d, out.begin());
    return;
  }
  const auto key = [&](int i) { return std::make_tuple(!survives(i), std::isnan(cost[i]) ? INFINITY : cost[i], i); };
  for (size_t i = 0; i < order.size(); ++i) order[i] = (int)i;
  std::partial_sort(order.begin(), order.begin() + elites, order.end(), [&](int x, int y) { return key(x) < key(y); });
  std::fill(out.begin(), out.end(), 0.0);
  for (int k = 0; k < elites; ++k)
    for (int q = 0; q < d; ++q) out[q] += delta[(size_t)order[k] * d + q] / elites;
}

}  // namespace

std::vector<sim::PdResult> track_bfm_search(FbAgent& agent, std::shared_ptr<const sim::Humanoid> h,
                                            const RefMotions& refs, const LatentSearchOptions& opt,
                                            const sim::PdOptions& pd, int window, SearchRows* rows) {
  check_search_options(opt);
  check_tracking_refs(&agent, *h, refs);
  if (window < 0) throw Error("track_bfm_search: window must be >= 0 (0 = the agent's track_window)");
  ag::NoGradGuard ng;
  const int S = opt.samples, D = refs.obs_dim, A = h->model()->nu, d = agent.config().z_dim;
  const int L = window > 0 ? window : agent.config().track_window;
  const bool standing = opt.start == TrackStart::standing;
  // What the body is scored against: the clips themselves, or (standing) moved to start where qpos0 stands.
  RefMotions moved;
  if (standing)
    for (int c = 0; c < refs.clips(); ++c)
      moved.add(*h, refs.names[c], sim::align_start(*h, refs.trajectory(c), h->model()->qpos0));
  const RefMotions& target = standing ? moved : refs;
  const auto fail_at = [&](int frame) {  // the fail distance at reference frame `frame`
    return standing && frame < opt.transition ? std::max(pd.fail_distance, opt.transition_fail_distance)
                                              : pd.fail_distance;
  };
  const std::vector<int>& bodies = h->tracked_bodies();
  const size_t J = bodies.size();
  std::vector<std::unique_ptr<sim::Env>> envs;  // one per candidate
  for (int i = 0; i < S; ++i) envs.push_back(std::make_unique<sim::Env>(h));
  sim::Env body(h);  // the tracked body
  Tensor obs = Tensor::empty({S, D}), zc = Tensor::empty({S, d});  // the candidates' batch
  Tensor obs1 = Tensor::empty({1, D}), z1 = Tensor::empty({1, d});  // the tracked body
  std::vector<double> delta((size_t)S * d), prev((size_t)d), zero((size_t)d, 0.0), cost((size_t)S), worst((size_t)S);
  std::vector<int> order((size_t)S);
  std::vector<float> act((size_t)A);
  sim::EnvState now;
  std::vector<sim::PdResult> out;
  for (int c = 0; c < refs.clips(); ++c) {
    const int T = refs.frames(c);
    const Tensor z = agent.infer_tracking_z(clip_states(refs, c), L).contiguous();  // [T-1, d], Eq 2
    const float* zt = z.data<float>();
    const sim::QposTrajectory traj = target.trajectory(c);
    if (standing)
      body.reset(nullptr, nullptr, nullptr);  // the model's defaults: qpos0 at rest
    else
      body.reset(traj.qpos.data(), traj.qvel.data(), nullptr);
    sim::TrackingScorer score(*h, traj, pd);
    score.add_frame(body);
    std::mt19937_64 rng(opt.seed + (uint64_t)c);
    std::mt19937_64 noise_rng(opt.seed + (uint64_t)c + 0x9E3779B97F4A7C15ull);  // action noise only
    std::normal_distribution<double> normal(0.0, 1.0);
    std::fill(prev.begin(), prev.end(), 0.0);
    bool planning = true;
    for (int t = 0; t + 1 < T;) {
      const int w = std::min(opt.window, T - 1 - t);
      if (planning) {
        const int steps = std::min(opt.window * opt.horizon, T - 1 - t);
        for (int i = 0; i < S; ++i)
          for (int k = 0; k < d; ++k)
            delta[(size_t)i * d + k] = i == 0 ? 0.0 : i == 1 ? prev[k] : opt.carry * prev[k] + opt.sigma * normal(rng);
        body.save_state(now);
        for (int i = 0; i < S; ++i) {
          envs[i]->restore_state(now);
          envs[i]->observe(obs.data<float>() + (size_t)i * D);
          cost[i] = 0, worst[i] = 0;
        }
        for (int s = 1; s <= steps; ++s) {  // frame t + s; its latent z_{t+s-1}
          for (int i = 0; i < S; ++i)
            offset_latent(zt + (size_t)(t + s - 1) * d, delta.data() + (size_t)i * d, d,
                          zc.data<float>() + (size_t)i * d);
          const Tensor a = agent.actor_mean(obs, zc).contiguous();  // [S, A]
          const float* ref = target.body_pos.data() + (size_t)target.global_frame(c, t + s) * J * 3;
          const double fail = fail_at(t + s);
#pragma omp parallel for schedule(dynamic)
          for (int i = 0; i < S; ++i) {
            if (!std::isfinite(worst[i])) continue;  // a dropped candidate stops simulating
            envs[i]->step(a.data<float>() + (size_t)i * A, obs.data<float>() + (size_t)i * D);
            cost[i] += candidate_frame_cost(*envs[i], bodies, ref, fail, &worst[i]);
          }
        }
        choose_offset(delta, cost, worst, opt.elites, d, order, prev);
      }
      bool failed = false;
      for (int s = 1; s <= w; ++s) {
        body.observe(obs1.data<float>());
        offset_latent(zt + (size_t)(t + s - 1) * d, planning ? prev.data() : zero.data(), d, z1.data<float>());
        const Tensor a = agent.actor_mean(obs1, z1).contiguous();
        if (rows != nullptr && planning) {
          rows->add(obs1.data<float>(), D, zt + (size_t)(t + s - 1) * d, d, a.data<float>(), A, c, t + s - 1);
        }
        if (opt.action_noise > 0) {
          std::copy_n(a.data<float>(), A, act.begin());
          for (float& v : act) v = std::clamp((float)(v + opt.action_noise * normal(noise_rng)), -1.0f, 1.0f);
          body.step(act.data(), nullptr);
        } else {
          body.step(a.data<float>(), nullptr);
        }
        score.add_frame(body);
        failed = failed || score.last_frame_error() >= fail_at(t + s);
      }
      t += w;
      if (failed) planning = false;
    }
    out.push_back(score.result());
  }
  return out;
}

}  // namespace t2m::bfm
