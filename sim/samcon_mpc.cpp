// samcon_mpc.cpp — the closed-loop window planner of samcon_mpc.h.
#include "sim/samcon_mpc.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "sim/env.h"
#include "sim/samcon_window.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"

namespace t2m::sim {
namespace {

void check_options(const SamconMpcOptions& o) {
  const bool ok = o.samples >= 1 && o.window >= 1 && o.horizon >= 1 && o.sigma >= 0 && std::isfinite(o.sigma) &&
                  o.target_noise >= 0 && std::isfinite(o.target_noise) && o.carry >= 0 && o.carry <= 1 &&
                  o.temperature >= 0 && std::isfinite(o.temperature) && o.size_cost >= 0 && std::isfinite(o.size_cost) &&
                  o.change_cost >= 0 && std::isfinite(o.change_cost) && o.driver_share >= 0 &&
                  o.driver_share <= 1;
  if (!ok)
    throw Error("track_samcon_mpc: bad options (samples " + std::to_string(o.samples) + ", window " +
                std::to_string(o.window) + ", horizon " + std::to_string(o.horizon) + ", sigma " +
                std::to_string(o.sigma) + ", carry " + std::to_string(o.carry) + ", target noise " +
                std::to_string(o.target_noise) + ", temperature " + std::to_string(o.temperature) +
                ", size cost " + std::to_string(o.size_cost) + ", change cost " + std::to_string(o.change_cost) +
                ", driver share " + std::to_string(o.driver_share) +
                "): need samples, window, horizon >= 1, finite sigma, noise, temperature and costs >= 0, carry and "
                "driver share in [0, 1]");
}

// 1 for the hinges that get offsets (opt.hinges, or all when empty).
std::vector<char> offset_mask(const SamconMpcOptions& o, int nu) {
  std::vector<char> mask((size_t)nu, o.hinges.empty() ? 1 : 0);
  for (int k : o.hinges) {
    if (k < 0 || k >= nu || mask[(size_t)k]) throw Error("track_samcon_mpc: offset hinge " + std::to_string(k) +
                                                         " outside [0, " + std::to_string(nu) + ") or repeated");
    mask[(size_t)k] = 1;
  }
  return mask;
}

}  // namespace

std::vector<int> lower_body_actuators(const Humanoid& h) {
  const mjModel* m = h.model();
  std::vector<int> out;
  for (int k = 0; k < m->nu; ++k) {
    const char* name = mj_id2name(m, mjOBJ_ACTUATOR, k);
    const std::string n = name ? name : "";
    for (const char* body : {"Spine_", "Chest_", "UpperLeg_", "LowerLeg_", "Foot_", "Toes_"})
      if (n.rfind(body, 0) == 0) {
        out.push_back(k);
        break;
      }
  }
  return out;
}

SamconMpcResult track_samcon_mpc(const std::shared_ptr<const Humanoid>& h, const QposTrajectory& ref,
                                 const SamconMpcOptions& opt, const PdOptions& pd, const BodyDriver& driver) {
  check_options(opt);
  samcon_detail::SearchContext ctx = samcon_detail::make_search_context("track_samcon_mpc", h, ref, opt.balance);
  const int T = ref.frames, nt = (int)ctx.envs.size(), S = opt.samples;
  Env body(h);  // the tracked body
  const int nu = body.model()->nu;
  const std::vector<char> mask = offset_mask(opt, nu);
  const double inv_nmask = 1.0 / (double)(opt.hinges.empty() ? (size_t)nu : opt.hinges.size());  // costs: means

  SamconMpcResult res;
  res.offset.assign((size_t)std::max(T - 1, 0) * nu, 0.0);
  res.ctrl.assign(res.offset.size(), 0.0);
  TrackingScorer score(*h, ref, pd);
  body.reset(ref.qpos.data(), ref.qvel.data(), nullptr);
  score.add_frame(body);

  std::mt19937_64 rng(opt.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<double> offsets((size_t)S * nu), cost((size_t)S), worst((size_t)S), prev((size_t)nu, 0.0);
  std::vector<double> applied((size_t)nu), mean((size_t)nu);
  EnvState now;
  bool planning = true;
  int t = 0;
  while (t + 1 < T) {
    const int w = std::min(opt.window, T - 1 - t);
    if (planning) {
      const int steps = std::min(opt.window * opt.horizon, T - 1 - t);
      body.save_state(now);
      for (int i = 0; i < S; ++i)
        for (int k = 0; k < nu; ++k)
          offsets[(size_t)i * nu + k] = !mask[(size_t)k] ? 0.0
                                        : i == 0     ? 0.0
                                        : i == 1     ? prev[k]
                                                     : opt.carry * prev[k] + opt.sigma * normal(rng);
#pragma omp parallel for schedule(dynamic) num_threads(nt)
      for (int i = 0; i < S; ++i) {
        Env& env = *ctx.envs[(size_t)omp_get_thread_num()];
        env.restore_state(now);
        cost[(size_t)i] = samcon_detail::simulate_candidate(env, ctx, ref, t, steps, offsets.data() + (size_t)i * nu,
                                                            &worst[(size_t)i]);
        double size = 0, change = 0;  // the learnable teacher's preference (options)
        for (int k = 0; k < nu; ++k) {
          const double d = offsets[(size_t)i * nu + k];
          size += d * d, change += (d - prev[(size_t)k]) * (d - prev[(size_t)k]);
        }
        cost[(size_t)i] += (opt.size_cost * size + opt.change_cost * change) * inv_nmask;
      }
      int best = 0;  // survivors first, then the cost, then the index
      auto better = [&](int a, int b) {
        const bool sa = worst[(size_t)a] < pd.fail_distance, sb = worst[(size_t)b] < pd.fail_distance;
        return sa != sb ? sa : cost[(size_t)a] < cost[(size_t)b];
      };
      for (int i = 1; i < S; ++i)
        if (better(i, best)) best = i;
      std::copy(offsets.begin() + (size_t)best * nu, offsets.begin() + (size_t)(best + 1) * nu, prev.begin());
      if (opt.temperature > 0 && worst[(size_t)best] < pd.fail_distance) {  // survivors' weighted mean
        const double c0 = cost[(size_t)best], scale = opt.temperature * std::max(c0, 1e-12);
        std::fill(mean.begin(), mean.end(), 0.0);
        double wsum = 0;
        for (int i = 0; i < S; ++i) {
          if (!(worst[(size_t)i] < pd.fail_distance)) continue;
          const double w = std::exp(-(cost[(size_t)i] - c0) / scale);
          wsum += w;
          for (int k = 0; k < nu; ++k) mean[(size_t)k] += w * offsets[(size_t)i * nu + k];
        }
        for (double& v : mean) v /= wsum;
        Env& env = *ctx.envs[0];
        env.restore_state(now);
        double mean_worst = 0;
        samcon_detail::simulate_candidate(env, ctx, ref, t, steps, mean.data(), &mean_worst);
        if (mean_worst < pd.fail_distance) prev = mean;
      }
    }
    bool failed = false;
    // DAgger: the driver leads this window (a draw only for shares strictly between 0 and 1)
    const bool driven = driver && opt.driver_share > 0 &&
                        (opt.driver_share >= 1 || uniform(rng) < opt.driver_share);
    for (int s = 1; s <= w; ++s) {
      double* off = res.offset.data() + (size_t)(t + s - 1) * nu;
      double* ctrl = res.ctrl.data() + (size_t)(t + s - 1) * nu;
      if (planning) std::copy(prev.begin(), prev.end(), off);
      for (int k = 0; k < nu; ++k) applied[(size_t)k] = opt.target_noise > 0 ? opt.target_noise * normal(rng) : 0.0;
      if (driven) {
        driver(body, t + s, ctrl);
        for (int k = 0; k < nu; ++k) {
          if (!std::isfinite(ctrl[k]))
            throw Error("track_samcon_mpc: the driver's target " + std::to_string(k) + " is not finite");
          ctrl[k] += applied[(size_t)k];
        }
        clamp_to_ctrlrange(body.model(), ctrl);
        body.step_targets(ctrl, nullptr);
      } else {
        for (int k = 0; k < nu; ++k) applied[(size_t)k] += off[k];
        samcon_detail::step_with_offset(body, ref, ctx.bref, ctx.bo, t + s, applied.data(), ctrl);
      }
      score.add_frame(body);
      failed = failed || score.last_frame_error() >= pd.fail_distance;
    }
    t += w;
    if (planning) res.frames_planned = t;
    if (failed) planning = false;
  }
  res.track = score.result();
  return res;
}

}  // namespace t2m::sim
