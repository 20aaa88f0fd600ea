// planner_demos.cpp — loading, replaying and labelling the planner's demonstrations (see planner_demos.h).
#include "models/bfm/planner_demos.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>

#include "autograd/no_grad.h"
#include "models/data/dataset.h"
#include "sim/env.h"
#include "sim/pd_tracker.h"
#include "sim/observation.h"
#include "sim/retarget.h"

namespace t2m::bfm {

namespace fs = std::filesystem;

namespace {

const char* kSuffix = ".ctrl.json";

// The rows of one run: obs / next_obs [n, D], applied action and label [n, A].
struct RunRows {
  std::vector<float> obs, next_obs, action, label;
  std::string error;
};

RunRows replay_run(const std::shared_ptr<const sim::Humanoid>& h, const RefMotions& refs, int c,
                   const sim::CtrlSequence& seq, int n, const std::string& qpos_path, const PlannerDemoOptions& opt) {
  RunRows r;
  sim::Env env(h);  // the planner's body: default options
  const int D = env.obs_dim(), A = env.action_dim(), nq = env.nq();
  sim::QposTrajectory ref = refs.trajectory(c);
  ref.fps = seq.fps;  // the run's frame rate (the expert's reference velocities are differences over 1 / fps)
  const sim::BalanceReference bref = sim::balance_reference(*h, ref);
  sim::BalanceOptions bo = opt.balance;
  bo.action_noise = 0;
  sim::QposTrajectory check;
  if (!qpos_path.empty()) check = sim::load_trajectory_json(*h, qpos_path);
  r.obs.resize((size_t)n * D), r.next_obs.resize((size_t)n * D);
  r.action.resize((size_t)n * A), r.label.resize((size_t)n * A);
  std::vector<double> ctrl((size_t)A);
  env.reset(ref.qpos.data(), ref.qvel.data(), r.obs.data());
  for (int t = 0; t < n; ++t) {
    if (t > 0) std::copy_n(r.next_obs.data() + (size_t)(t - 1) * D, D, r.obs.data() + (size_t)t * D);
    // The planner's clean action in this state (Eq of sim/samcon_mpc.h without the noise).
    sim::balance_targets(env, bref.frame(ref, t + 1), bo, ctrl.data());
    const double* off = seq.offset.data() + (size_t)t * A;
    for (int k = 0; k < A; ++k) ctrl[(size_t)k] += off[k];
    sim::clamp_to_ctrlrange(env.model(), ctrl.data());
    const double* applied = seq.ctrl.data() + (size_t)t * A;
    for (int k = 0; k < A; ++k) {
      r.label[(size_t)t * A + k] = (float)std::clamp(env.ctrl_to_action(k, ctrl[(size_t)k]), -1.0, 1.0);
      r.action[(size_t)t * A + k] = (float)std::clamp(env.ctrl_to_action(k, applied[k]), -1.0, 1.0);
    }
    env.step_targets(applied, r.next_obs.data() + (size_t)t * D);
    if (env.diverged()) {
      r.error = "the replay diverged at step " + std::to_string(t);
      return r;
    }
    if (check.frames > t + 1) {
      const double* want = check.qpos.data() + (size_t)(t + 1) * nq;
      for (int k = 0; k < nq; ++k)
        if (std::fabs(env.data()->qpos[k] - want[k]) > 1e-9) {
          r.error = "the replay departs from " + qpos_path + " at frame " + std::to_string(t + 1) + " (qpos " +
                    std::to_string(k) + ": " + std::to_string(env.data()->qpos[k]) + " vs " + std::to_string(want[k]) +
                    "): another physics build or another reference";
          return r;
        }
    }
  }
  return r;
}

}  // namespace

std::vector<std::string> demo_directories(const std::string& dirs) {
  std::vector<std::string> out;
  for (size_t b = 0; b <= dirs.size();) {
    const size_t e = std::min(dirs.find(',', b), dirs.size());
    out.push_back(dirs.substr(b, e - b));
    b = e + 1;
  }
  return out;
}

PlannerDemos load_planner_demos(const std::string& dirs, const RefMotions& refs, const PlannerDemoOptions& opt) {
  if (opt.drop_before_fail < 0) throw Error("planner demos: drop_before_fail must be >= 0");
  std::map<std::string, int> by_name;
  for (int c = 0; c < refs.clips(); ++c) by_name[refs.names[(size_t)c]] = c;
  PlannerDemos d;
  size_t ctrl_files = 0;
  for (const std::string& dir : demo_directories(dirs)) {
    if (!fs::is_directory(dir)) throw Error("planner demos: no directory " + dir);
    std::vector<std::string> files;
    for (const auto& en : fs::directory_iterator(dir)) {
      const std::string f = en.path().filename().string();
      if (f.size() > std::strlen(kSuffix) && f.compare(f.size() - std::strlen(kSuffix), std::string::npos, kSuffix) == 0)
        files.push_back(f);
    }
    std::sort(files.begin(), files.end());
    ctrl_files += files.size();
    for (const std::string& f : files) {
      const std::string name = f.substr(0, f.size() - std::strlen(kSuffix));
      const auto it = by_name.find(name);
      if (it == by_name.end()) {
        d.skipped.push_back(f);
        continue;
      }
      const int c = it->second;
      sim::CtrlSequence s = sim::load_ctrl_json(dir + "/" + f);
      if (s.steps() != refs.frames(c) - 1)
        throw Error("planner demos: " + dir + "/" + f + " has " + std::to_string(s.steps()) + " control steps, its clip " +
                    std::to_string(refs.frames(c)) + " frames (a run on another reference?)");
      const bool failed = s.frames_searched < s.steps();
      const int n = failed ? std::max(0, s.frames_searched - opt.drop_before_fail) : s.frames_searched;
      d.failed_runs += failed;
      if (n == 0) continue;
      d.files.push_back(f);
      d.clip.push_back(c);
      const std::string qp = dir + "/" + name + ".qpos.json";
      d.qpos_paths.push_back(fs::exists(qp) ? qp : std::string());
      d.steps.push_back(n);
      d.rows += n;
      d.seq.push_back(std::move(s));
    }
  }
  if (d.files.empty())
    throw Error("planner demos: no usable NAME.ctrl.json in " + dirs + " (" + std::to_string(ctrl_files) +
                " ctrl files, " + std::to_string(d.skipped.size()) + " not naming a reference clip)");
  return d;
}

void replay_planner_demos(const std::shared_ptr<const sim::Humanoid>& h, const RefMotions& refs,
                          const PlannerDemos& demos, ReplayBuffer& buf, const PlannerDemoOptions& opt) {
  const int A = h->model()->nu;
  const int N = (int)demos.files.size();
  for (int i = 0; i < N; ++i)
    if (demos.seq[(size_t)i].nu != A)
      throw Error("planner demos: " + demos.files[(size_t)i] + " has nu " + std::to_string(demos.seq[(size_t)i].nu) +
                  ", the humanoid " + std::to_string(A));
  if (!buf.has_expert_labels() || buf.obs_dim() != refs.obs_dim || buf.action_dim() != A)
    throw Error("planner demos: the buffer needs expert labels and dims (" + std::to_string(refs.obs_dim) + ", " +
                std::to_string(A) + ")");
  std::vector<RunRows> runs((size_t)N);
#pragma omp parallel for schedule(dynamic)
  for (int i = 0; i < N; ++i) {
    try {  // errors are reported after the loop, in file order
      runs[(size_t)i] = replay_run(h, refs, demos.clip[(size_t)i], demos.seq[(size_t)i], demos.steps[(size_t)i],
                                   demos.qpos_paths[(size_t)i], opt);
    } catch (const std::exception& e) {
      runs[(size_t)i].error = e.what();
    }
  }
  const int D = refs.obs_dim;
  for (int i = 0; i < N; ++i) {
    const RunRows& r = runs[(size_t)i];
    if (!r.error.empty()) throw Error("planner demos: " + demos.files[(size_t)i] + ": " + r.error);
    for (int t = 0; t < demos.steps[(size_t)i]; ++t)
      buf.add(r.obs.data() + (size_t)t * D, r.action.data() + (size_t)t * A, r.next_obs.data() + (size_t)t * D, 1.0f,
              demos.clip[(size_t)i], t, r.label.data() + (size_t)t * A);
  }
}

std::vector<char> planner_owned_clips(const RefMotions& refs, const PlannerDemos& demos) {
  std::set<std::string> contents;
  for (int c : demos.clip) contents.insert(data::clip_content(refs.names[(size_t)c]));
  contents.erase(std::string());
  std::vector<char> owned((size_t)refs.clips(), 0);
  for (int c = 0; c < refs.clips(); ++c) owned[(size_t)c] = contents.count(data::clip_content(refs.names[(size_t)c])) > 0;
  return owned;
}

sim::BodyDriver policy_driver(FbAgent& agent, const std::shared_ptr<const sim::Humanoid>& h,
                              const sim::QposTrajectory& ref) {
  const int D = agent.config().obs_dim, d = agent.config().z_dim, A = agent.config().action_dim;
  if (h->model()->nu != A || sim::observation_dim((int)h->tracked_bodies().size()) != D)
    throw Error("policy driver: the policy's dims do not match the humanoid");
  const std::vector<float> states = sim::replay_observations(*h, ref);  // [T, D]
  Tensor z;
  {
    ag::NoGradGuard ng;
    z = agent.infer_tracking_z(Tensor::from_vector(states, {(int64_t)ref.frames, (int64_t)D})).contiguous();  // [T-1, d]
  }
  auto obs = std::make_shared<Tensor>(Tensor::empty({1, D}));
  auto zt = std::make_shared<Tensor>(Tensor::empty({1, d}));
  return [&agent, z, obs, zt, d, A](const sim::Env& body, int t, double* ctrl) {
    if (t < 1 || t > z.shape()[0]) throw Error("policy driver: frame " + std::to_string(t) + " outside the clip");
    body.observe(obs->data<float>());
    std::copy_n(z.data<float>() + (int64_t)(t - 1) * d, d, zt->data<float>());
    ag::NoGradGuard ng;
    const Tensor a = agent.actor_mean(*obs, *zt).contiguous();
    for (int k = 0; k < A; ++k) ctrl[k] = body.action_to_ctrl(k, a.data<float>()[k]);
  };
}

}  // namespace t2m::bfm
