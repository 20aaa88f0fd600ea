// collect.cpp — parallel tracking episodes (noisy expert tracker or policy) into a replay buffer (see collect.h).
#include "models/bfm/collect.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

#include "autograd/no_grad.h"
#include "models/bfm/sphere_projection.h"
#include "sim/skeleton.h"

namespace t2m::bfm {

namespace {
// One uniform integer in [0, n) from one Philox counter.
int64_t draw_index(Generator& gen, int64_t n) {
  uint32_t r[4];
  philox4x32(gen.seed(), gen.advance(1), r);
  return (int64_t)((((uint64_t)r[1] << 32) | r[0]) % (uint64_t)n);
}
}  // namespace

// Text2BFM Eq 2: z = Proj(mean of B over the H = min(L, T-1-t) states after frame t).
Tensor window_latents(const RefMotions& refs, const int64_t* clip, const int64_t* frame, int64_t n, int L,
                      const EncodeFn& encode) {
  if (L < 1) throw Error("window_latents: L = " + std::to_string(L) + " (must be >= 1)");
  const int D = refs.obs_dim;
  std::vector<int64_t> first(n), count(n);
  int64_t rows = 0;
  for (int64_t i = 0; i < n; ++i) {
    const int T = refs.frames((int)clip[i]);
    if (frame[i] < 0 || frame[i] >= T - 1)
      throw Error("window_latents: frame " + std::to_string(frame[i]) + " has no successor in clip " +
                  refs.names[clip[i]] + " (" + std::to_string(T) + " frames)");
    first[i] = rows;
    count[i] = std::min<int64_t>(L, T - 1 - frame[i]);
    rows += count[i];
  }
  Tensor states = Tensor::empty({rows, D});
  float* s = states.data<float>();
  for (int64_t i = 0; i < n; ++i)
    for (int64_t k = 0; k < count[i]; ++k)
      std::memcpy(s + (first[i] + k) * D, refs.obs_at((int)clip[i], (int)(frame[i] + 1 + k)), sizeof(float) * D);
  const Tensor b = encode(states).contiguous();
  if (b.dim() != 2 || b.size(0) != rows) throw Error("window_latents: encoder returned " + shape_str(b.shape()) +
                                                     " for " + std::to_string(rows) + " states");
  const int64_t d = b.size(1);
  Tensor mean = Tensor::zeros({n, d});
  const float* bp = b.data<float>();
  float* mp = mean.data<float>();
  for (int64_t i = 0; i < n; ++i) {
    for (int64_t k = 0; k < count[i]; ++k)
      for (int64_t j = 0; j < d; ++j) mp[i * d + j] += bp[(first[i] + k) * d + j];
    for (int64_t j = 0; j < d; ++j) mp[i * d + j] /= (float)count[i];
  }
  return project_rows(mean, std::sqrt((double)d));
}

TrackingCollector::TrackingCollector(std::shared_ptr<const sim::Humanoid> h, const RefMotions& refs,
                                     CollectOptions opt)
    : h_(std::move(h)), refs_(refs), opt_(opt), venv_(h_, std::max(opt.envs, 1)) {
  if (opt.envs < 1 || opt.max_episode_steps < 1 || !(opt.fail_distance > 0) || !(opt.action_noise >= 0) ||
      opt.window < 1)
    throw Error("collect: bad options (envs " + std::to_string(opt.envs) + ", max_episode_steps " +
                std::to_string(opt.max_episode_steps) + ", fail_distance " + std::to_string(opt.fail_distance) +
                ", action_noise " + std::to_string(opt.action_noise) + ", window " + std::to_string(opt.window) + ")");
  const mjModel* m = h_->model();
  if (refs.clips() == 0 || refs.nq != m->nq || refs.nv != m->nv || refs.obs_dim != venv_.obs_dim())
    throw Error("collect: the reference motions do not match the humanoid (nq " + std::to_string(refs.nq) + ", nv " +
                std::to_string(refs.nv) + ", obs " + std::to_string(refs.obs_dim) + ")");
  for (int c = 0; c < refs.clips(); ++c)
    for (int t = 0; t + 1 < refs.frames(c); ++t) {
      starts_.push_back(refs.offset[c] + t);
      start_clip_.push_back(c);
    }
  const int N = opt.envs, D = venv_.obs_dim(), A = venv_.action_dim();
  st_.resize(N);
  obs_.resize((size_t)N * D);
  next_obs_.resize((size_t)N * D);
  actions_.resize((size_t)N * A);
  ctrl_.resize((size_t)N * A);
  labels_.resize((size_t)N * A);
  if (opt.expert == Expert::balance) {
    balance_ref_.resize(refs.clips());
    for (int c = 0; c < refs.clips(); ++c) balance_ref_[c] = sim::balance_reference(*h_, refs.trajectory(c));
  }
}

void TrackingCollector::start_episode(int e, Generator& gen) {
  const int64_t i = draw_index(gen, (int64_t)starts_.size());
  const int c = start_clip_[i];
  const int t = (int)(starts_[i] - refs_.offset[c]);
  st_[e] = EnvState{c, t, 0};
  venv_.env(e).reset(refs_.qpos_at(c, t), refs_.qvel_at(c, t), obs_.data() + (size_t)e * refs_.obs_dim);
}

Expert expert_from_string(const std::string& s) {
  if (s == "pd") return Expert::pd;
  if (s == "balance") return Expert::balance;
  throw Error("collect: unknown expert '" + s + "' (pd | balance)");
}
const char* expert_name(Expert e) { return e == Expert::pd ? "pd" : "balance"; }

void set_expert(CollectOptions& co, const std::string& name) {
  const bool hips = name == "balance-hips";
  if (!hips && name != "pd" && name != "balance")
    throw Error("collect: unknown expert '" + name + "' (pd | balance | balance-hips)");
  co.expert = expert_from_string(hips ? "balance" : name);
  co.balance.torque_at_hips_only = hips;
}

void TrackingCollector::expert_labels() {
  const int N = opt_.envs, A = venv_.action_dim();
  const mjModel* m = h_->model();
  // Targets of every env (parallel: each reads its own env), as noiseless actions.
#pragma omp parallel for schedule(static)
  for (int e = 0; e < N; ++e) {
    const int c = st_[e].clip, t = st_[e].frame + 1;
    const double* qr = refs_.qpos_at(c, t);
    const double* vr = refs_.qvel_at(c, t);
    double* ctrl = ctrl_.data() + (size_t)e * A;
    const sim::Env& env = venv_.env(e);
    if (opt_.expert == Expert::balance) {
      sim::balance_targets(env, balance_ref_[c].frame(qr, vr, t), opt_.balance, ctrl);
    } else {
      sim::pd_target_angles(m, qr, vr, /*feedforward=*/true, ctrl);
      sim::clamp_to_ctrlrange(m, ctrl);
    }
    for (int k = 0; k < A; ++k)
      labels_[(size_t)e * A + k] = (float)std::clamp(env.ctrl_to_action(k, ctrl[k]), -1.0, 1.0);
  }
}

void TrackingCollector::expert_actions(Generator& gen) {
  const int N = opt_.envs, A = venv_.action_dim();
  expert_labels();
  // Noise drawn serially (thread-independent).
  const Tensor noise = opt_.action_noise > 0 ? rand_normal({N, A}, gen, 0.0, opt_.action_noise) : Tensor();
  for (size_t i = 0; i < (size_t)N * A; ++i) {
    const double a = labels_[i] + (noise.defined() ? noise.data<float>()[i] : 0.0f);
    actions_[i] = (float)std::clamp(a, -1.0, 1.0);
  }
}

CollectStats TrackingCollector::collect_expert(int64_t n, Generator& gen, ReplayBuffer& buf) {
  return run(n, gen, buf, nullptr, nullptr);
}

CollectStats TrackingCollector::collect_policy(int64_t n, const EncodeFn& encode, const PolicyFn& policy,
                                               Generator& gen, ReplayBuffer& buf) {
  return run(n, gen, buf, &encode, &policy);
}

CollectStats TrackingCollector::run(int64_t n, Generator& gen, ReplayBuffer& buf, const EncodeFn* encode,
                                    const PolicyFn* policy) {
  if (n < 0) throw Error("collect: n = " + std::to_string(n));
  const int N = opt_.envs, D = venv_.obs_dim(), A = venv_.action_dim(), B = sim::kNumJoints;
  if (buf.obs_dim() != D || buf.action_dim() != A)
    throw Error("collect: buffer dims (" + std::to_string(buf.obs_dim()) + ", " + std::to_string(buf.action_dim()) +
                ") differ from the env's (" + std::to_string(D) + ", " + std::to_string(A) + ")");
  const auto t0 = std::chrono::steady_clock::now();
  CollectStats s;
  for (int e = 0; e < N; ++e) start_episode(e, gen);
  const auto& bodies = h_->tracked_bodies();
  std::vector<double> err(N);
  std::vector<int64_t> clip(N), frame(N);
  Tensor action;
  while (s.transitions < n) {
    if (policy) {
      ag::NoGradGuard ng;
      for (int e = 0; e < N; ++e) clip[e] = st_[e].clip, frame[e] = st_[e].frame;
      const Tensor z = window_latents(refs_, clip.data(), frame.data(), N, opt_.window, *encode);
      const Tensor obs = Tensor::from_vector(obs_, {N, D});
      (*policy)(obs, z, (float)opt_.action_noise, gen, action);
      if (!action.defined() || action.shape() != Shape{N, A})
        throw Error("collect: the policy returned actions of shape " +
                    (action.defined() ? shape_str(action.shape()) : std::string("undefined")) + ", expected " +
                    shape_str({N, A}));
      const Tensor ac = action.contiguous();
      for (int64_t i = 0; i < (int64_t)N * A; ++i) {
        const float a = ac.data<float>()[i];
        if (!std::isfinite(a)) throw Error("collect: the policy returned a non-finite action");
        actions_[i] = std::clamp(a, -1.0f, 1.0f);
      }
      if (buf.has_expert_labels()) expert_labels();  // DAgger: what the expert would do in the policy's states
    } else {
      expert_actions(gen);
    }
    venv_.step(actions_.data(), next_obs_.data());
    // Frame errors against the reference frame each env was tracking towards (parallel: read-only per env).
#pragma omp parallel for schedule(static)
    for (int e = 0; e < N; ++e) {
      const mjData* d = venv_.env(e).data();
      const float* ref = refs_.body_pos.data() + refs_.global_frame(st_[e].clip, st_[e].frame + 1) * B * 3;
      double mx = 0;
      for (int j = 0; j < B; ++j) {
        const double* p = d->xpos + 3 * bodies[j];
        const double dx = p[0] - ref[3 * j], dy = p[1] - ref[3 * j + 1], dz = p[2] - ref[3 * j + 2];
        mx = std::max(mx, std::sqrt(dx * dx + dy * dy + dz * dz));
      }
      err[e] = std::isfinite(mx) ? mx : INFINITY;
    }
    for (int e = 0; e < N; ++e) {  // serial, in env order: buffer rows and RNG draws do not depend on threads
      EnvState& es = st_[e];
      float* o = obs_.data() + (size_t)e * D;
      const float* no = next_obs_.data() + (size_t)e * D;
      if (venv_.env(e).diverged()) {
        ++s.diverged;
        start_episode(e, gen);
        continue;
      }
      if (s.transitions < n) {
        buf.add(o, actions_.data() + (size_t)e * A, no, 1.0f, es.clip, es.frame,
                buf.has_expert_labels() ? labels_.data() + (size_t)e * A : nullptr);
        ++s.transitions;
      }
      ++es.frame;
      ++es.steps;
      const bool fail = err[e] >= opt_.fail_distance;
      if (fail || es.frame + 1 >= refs_.frames(es.clip) || es.steps >= opt_.max_episode_steps) {
        ++s.episodes;
        s.failed += fail;
        s.ended_steps += es.steps;
        start_episode(e, gen);
      } else {
        std::memcpy(o, no, sizeof(float) * D);
      }
    }
  }
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

}  // namespace t2m::bfm
