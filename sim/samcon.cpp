// samcon.cpp — the pieces both searches share (samcon_window.h), and the window-by-window beam search of samcon.h
// with the replay of the path it keeps.
#include "sim/samcon.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <string>

#include "sim/env.h"
#include "sim/retarget.h"
#include "sim/samcon_window.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"

namespace t2m::sim {

double tracking_frame_cost(const mjData* d, const std::vector<int>& bodies, const float* ref_pos, double* worst) {
  double sum = 0, mx = 0;
  for (size_t j = 0; j < bodies.size(); ++j) {
    double e2 = 0;
    for (int c = 0; c < 3; ++c) {
      const double v = d->xpos[3 * bodies[j] + c] - (double)ref_pos[3 * j + c];
      e2 += v * v;
    }
    sum += e2;
    mx = std::max(mx, e2);
  }
  *worst = std::sqrt(mx);
  return sum / (double)bodies.size();
}


namespace samcon_detail {

// The expert's targets towards frame t plus the offset, clamped; the env advances one control step.
void step_with_offset(Env& env, const QposTrajectory& ref, const BalanceReference& bref, const BalanceOptions& bo,
                      int t, const double* offset, double* ctrl) {
  const mjModel* m = env.model();
  balance_targets(env, bref.frame(ref, t), bo, ctrl);
  for (int k = 0; k < m->nu; ++k) ctrl[k] += offset[k];
  clamp_to_ctrlrange(m, ctrl);
  env.step_targets(ctrl, nullptr);
}

SearchContext make_search_context(const char* who, const std::shared_ptr<const Humanoid>& h,
                                  const QposTrajectory& ref, const BalanceOptions& bo) {
  if (!h || !h->is_humanoid()) throw Error(std::string(who) + ": the model is not the t2m humanoid");
  check_tracking_reference(h->model(), ref, who);
  SearchContext c;
  c.bref = balance_reference(*h, ref);
  c.ref_pos = replay_joint_positions(*h, ref);
  c.bodies = h->tracked_bodies();
  c.bo = bo;
  c.bo.action_noise = 0;
  for (int i = 0, nt = std::max(1, get_num_threads()); i < nt; ++i) c.envs.push_back(std::make_unique<Env>(h));
  return c;
}

double simulate_candidate(Env& env, const SearchContext& c, const QposTrajectory& ref, int t, int steps,
                          const double* offset, double* worst) {
  std::vector<double> ctrl((size_t)env.model()->nu);
  const size_t J = c.bodies.size();
  double cost = 0, mx = 0;
  for (int s = 1; s <= steps; ++s) {
    step_with_offset(env, ref, c.bref, c.bo, t + s, offset, ctrl.data());
    double w = 0;
    cost += tracking_frame_cost(env.data(), c.bodies, c.ref_pos.data() + (size_t)(t + s) * J * 3, &w);
    mx = std::max(mx, env.diverged() ? INFINITY : w);
  }
  *worst = mx;
  return cost;
}

}  // namespace samcon_detail

namespace {

using samcon_detail::SearchContext;
using samcon_detail::step_with_offset;

void check_options(const SamconOptions& o) {
  if (o.samples < 1 || o.beam < 1 || o.beam > o.samples || o.window < 1 || !(o.sigma >= 0) || !std::isfinite(o.sigma))
    throw Error("track_samcon: bad options (samples " + std::to_string(o.samples) + ", beam " +
                std::to_string(o.beam) + ", window " + std::to_string(o.window) + ", sigma " +
                std::to_string(o.sigma) + "): need samples >= beam >= 1, window >= 1, finite sigma >= 0");
}

struct Candidate {
  int parent = 0;             // index into the previous window's kept states
  std::vector<double> offset;  // [nu]
  double cost = 0, worst = 0;
  EnvState end;
};

struct Kept {
  EnvState state;
  int path = -1;  // node in the path tree
};

struct PathNode {
  int parent = -1;
  std::vector<double> offset;  // [nu], for every step of its window
};

}  // namespace

SamconResult track_samcon(const std::shared_ptr<const Humanoid>& h, const QposTrajectory& ref,
                          const SamconOptions& opt, const PdOptions& pd) {
  check_options(opt);
  SearchContext ctx = samcon_detail::make_search_context("track_samcon", h, ref, opt.balance);
  const int T = ref.frames, nt = (int)ctx.envs.size();
  auto& envs = ctx.envs;
  const int nu = envs[0]->model()->nu;

  std::vector<PathNode> tree;
  std::vector<Kept> kept(1);
  envs[0]->reset(ref.qpos.data(), ref.qvel.data(), nullptr);
  envs[0]->save_state(kept[0].state);
  std::mt19937_64 rng(opt.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<Candidate> cand((size_t)opt.samples);
  int t = 0;
  while (t + 1 < T) {
    const int w = std::min(opt.window, T - 1 - t), nk = (int)kept.size();
    for (int i = 0; i < opt.samples; ++i) {
      Candidate& c = cand[(size_t)i];
      c.parent = i % nk;
      c.offset.assign((size_t)nu, 0.0);
      if (i >= nk)
        for (auto& v : c.offset) v = opt.sigma * normal(rng);
    }
#pragma omp parallel for schedule(dynamic) num_threads(nt)
    for (int i = 0; i < opt.samples; ++i) {
      Candidate& c = cand[(size_t)i];
      Env& env = *envs[(size_t)omp_get_thread_num()];
      env.restore_state(kept[(size_t)c.parent].state);
      c.cost = samcon_detail::simulate_candidate(env, ctx, ref, t, w, c.offset.data(), &c.worst);
      env.save_state(c.end);
    }
    std::vector<int> order;
    for (int i = 0; i < opt.samples; ++i)
      if (cand[(size_t)i].worst < pd.fail_distance) order.push_back(i);
    if (order.empty()) break;
    std::sort(order.begin(), order.end(), [&](int a, int b) {
      return cand[(size_t)a].cost < cand[(size_t)b].cost || (cand[(size_t)a].cost == cand[(size_t)b].cost && a < b);
    });
    order.resize(std::min<size_t>(order.size(), (size_t)opt.beam));
    std::vector<Kept> next(order.size());
    for (size_t r = 0; r < order.size(); ++r) {
      Candidate& c = cand[(size_t)order[r]];
      tree.push_back({kept[(size_t)c.parent].path, c.offset});
      next[r].path = (int)tree.size() - 1;
      next[r].state = std::move(c.end);
    }
    kept = std::move(next);
    t += w;
  }

  SamconResult res;
  res.frames_searched = t;
  // The cheapest kept path, window by window from the start; steps past the searched frames use no offset.
  std::vector<int> windows;
  for (int n = kept[0].path; n >= 0; n = tree[(size_t)n].parent) windows.push_back(n);
  std::reverse(windows.begin(), windows.end());
  res.offset.assign((size_t)(T - 1) * nu, 0.0);
  for (size_t k = 0; k < windows.size(); ++k)
    for (int s = 0; s < opt.window && (int)k * opt.window + s < T - 1; ++s)
      std::copy(tree[(size_t)windows[k]].offset.begin(), tree[(size_t)windows[k]].offset.end(),
                res.offset.begin() + ((size_t)k * opt.window + s) * nu);

  // Replay from the reference start and score it like track_pd.
  Env& env = *envs[0];
  TrackingScorer score(*h, ref, pd);
  env.reset(ref.qpos.data(), ref.qvel.data(), nullptr);
  score.add_frame(env);
  res.ctrl.assign((size_t)(T - 1) * nu, 0.0);
  for (int f = 1; f < T; ++f) {
    step_with_offset(env, ref, ctx.bref, ctx.bo, f, res.offset.data() + (size_t)(f - 1) * nu,
                     res.ctrl.data() + (size_t)(f - 1) * nu);
    score.add_frame(env);
  }
  res.track = score.result();
  return res;
}

}  // namespace t2m::sim
