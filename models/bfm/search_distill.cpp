// search_distill.cpp — the rows files, the anchor rollouts and the actor fit of search_distill.h.
#include "models/bfm/search_distill.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include "autograd/no_grad.h"
#include "autograd/ops_elementwise.h"
#include "models/bfm/fb_networks.h"
#include "models/bfm/track_eval.h"
#include "nn/checkpoint.h"
#include "nn/loss_regression.h"
#include "nn/optim_adamw.h"
#include "sim/env.h"

namespace t2m::bfm {

namespace {
constexpr const char* kFormat = "t2m-search-rows-1";

Tensor floats(const std::vector<float>& v, int64_t rows, int64_t cols) {
  Tensor t = Tensor::empty({rows, cols});
  std::copy(v.begin(), v.end(), t.data<float>());
  return t;
}
Tensor ints(const std::vector<int>& v) {
  Tensor t = Tensor::empty({(int64_t)v.size()}, DType::i64);
  std::copy(v.begin(), v.end(), t.data<int64_t>());
  return t;
}

void check_rows(const SearchRows& r, int D, int d, int A, const std::string& who) {
  const size_t R = (size_t)r.rows();
  if (r.frame.size() != R || r.obs.size() != R * D || r.z.size() != R * d || r.action.size() != R * A)
    throw Error(who + ": rows of other dims than the agent's (obs " + std::to_string(D) + ", z " + std::to_string(d) +
                ", action " + std::to_string(A) + ")");
}

// (batch rows of r) -> s [B, D], z [B, d], a [B, A]; rows idx.
void gather(const SearchRows& r, const std::vector<int64_t>& idx, int D, int d, int A, Tensor& s, Tensor& z, Tensor& a) {
  const int64_t B = (int64_t)idx.size();
  s = Tensor::empty({B, D}), z = Tensor::empty({B, d}), a = Tensor::empty({B, A});
  for (int64_t i = 0; i < B; ++i) {
    std::memcpy(s.data<float>() + i * D, r.obs.data() + idx[i] * D, sizeof(float) * D);
    std::memcpy(z.data<float>() + i * d, r.z.data() + idx[i] * d, sizeof(float) * d);
    std::memcpy(a.data<float>() + i * A, r.action.data() + idx[i] * A, sizeof(float) * A);
  }
}

// RMS |mu(s, z) - a| over up to 4096 rows spread evenly over r.
double rms_to_labels(FbAgent& agent, const SearchRows& r) {
  const int D = agent.config().obs_dim, d = agent.config().z_dim, A = agent.config().action_dim;
  const int64_t R = r.rows(), n = std::min<int64_t>(R, 4096);
  if (n == 0) return 0.0;
  std::vector<int64_t> idx((size_t)n);
  for (int64_t i = 0; i < n; ++i) idx[i] = i * R / n;
  Tensor s, z, a;
  gather(r, idx, D, d, A, s, z, a);
  const Tensor m = agent.actor_mean(s, z).contiguous();
  double e = 0;
  for (int64_t i = 0; i < m.numel(); ++i) {
    const double q = (double)m.data<float>()[i] - a.data<float>()[i];
    e += q * q;
  }
  return std::sqrt(e / m.numel());
}
}  // namespace

void save_search_rows(const SearchRows& rows, const std::vector<std::string>& names, const std::string& path,
                      const nlohmann::json& meta) {
  const int64_t R = rows.rows();
  if (R == 0 || rows.frame.size() != (size_t)R || rows.obs.size() % R || rows.z.size() % R || rows.action.size() % R)
    throw Error("search rows " + path + ": nothing to write or inconsistent row arrays");
  for (int c : rows.clip)
    if (c < 0 || c >= (int)names.size()) throw Error("search rows " + path + ": clip index outside the names");
  nn::Checkpoint ck;
  ck.meta = meta;
  ck.meta["format"] = kFormat;
  ck.meta["clips"] = names;
  ck.put("obs", floats(rows.obs, R, (int64_t)rows.obs.size() / R));
  ck.put("z", floats(rows.z, R, (int64_t)rows.z.size() / R));
  ck.put("action", floats(rows.action, R, (int64_t)rows.action.size() / R));
  ck.put("clip", ints(rows.clip));
  ck.put("frame", ints(rows.frame));
  ck.save(path);
}

SearchRows load_search_rows(const std::string& path, int D, int d, int A, std::vector<std::string>* names) {
  const nn::Checkpoint ck = nn::Checkpoint::load(path);
  if (ck.meta.value("format", std::string()) != kFormat || !ck.meta.contains("clips") || !ck.meta["clips"].is_array())
    throw Error("search rows " + path + ": not a search rows file (format " + kFormat + ")");
  const std::vector<std::string> clips = ck.meta["clips"].get<std::vector<std::string>>();
  if (!ck.has("clip")) throw Error("search rows " + path + ": no tensor 'clip'");
  const int64_t R = ck.get("clip").numel();
  SearchRows r;
  try {
    const auto copy_f = [&](const char* n, int64_t cols, std::vector<float>& out) {
      const Tensor& t = ck.expect(n, {R, cols}, DType::f32);
      out.assign(t.data<float>(), t.data<float>() + R * cols);
    };
    copy_f("obs", D, r.obs);
    copy_f("z", d, r.z);
    copy_f("action", A, r.action);
    const Tensor& c = ck.expect("clip", {R}, DType::i64);
    const Tensor& f = ck.expect("frame", {R}, DType::i64);
    r.clip.assign(c.data<int64_t>(), c.data<int64_t>() + R);
    r.frame.assign(f.data<int64_t>(), f.data<int64_t>() + R);
  } catch (const Error& e) {
    throw Error("search rows " + path + ": " + e.what());
  }
  for (int c : r.clip)
    if (c < 0 || c >= (int)clips.size()) throw Error("search rows " + path + ": clip index outside its names");
  if (names) *names = clips;
  return r;
}

void append_search_rows(SearchRows& dst, const SearchRows& src, int clip_offset) {
  dst.obs.insert(dst.obs.end(), src.obs.begin(), src.obs.end());
  dst.z.insert(dst.z.end(), src.z.begin(), src.z.end());
  dst.action.insert(dst.action.end(), src.action.begin(), src.action.end());
  for (int c : src.clip) dst.clip.push_back(c + clip_offset);
  dst.frame.insert(dst.frame.end(), src.frame.begin(), src.frame.end());
}

SearchRows plain_tracking_rows(FbAgent& agent, std::shared_ptr<const sim::Humanoid> h, const RefMotions& refs,
                               double noise, uint64_t seed, const sim::PdOptions& pd) {
  check_tracking_refs(&agent, *h, refs);
  if (!(noise >= 0) || !std::isfinite(noise)) throw Error("plain_tracking_rows: noise must be finite and >= 0");
  ag::NoGradGuard ng;
  const int D = refs.obs_dim, d = agent.config().z_dim, A = h->model()->nu;
  const size_t J = h->tracked_bodies().size();
  SearchRows out;
  Tensor o1 = Tensor::empty({1, D}), z1 = Tensor::empty({1, d});
  std::vector<float> act((size_t)A);
  sim::Env body(h);
  for (int c = 0; c < refs.clips(); ++c) {
    const Tensor z = agent.infer_tracking_z(clip_states(refs, c)).contiguous();  // [T-1, d]
    const sim::QposTrajectory traj = refs.trajectory(c);
    body.reset(traj.qpos.data(), traj.qvel.data(), nullptr);
    std::mt19937_64 rng(seed + (uint64_t)c);
    std::normal_distribution<double> normal(0.0, 1.0);
    for (int t = 0; t + 1 < refs.frames(c); ++t) {
      body.observe(o1.data<float>());
      std::copy_n(z.data<float>() + (size_t)t * d, d, z1.data<float>());
      const Tensor a = agent.actor_mean(o1, z1).contiguous();
      out.add(o1.data<float>(), D, z1.data<float>(), d, a.data<float>(), A, c, t);
      for (int k = 0; k < A; ++k)
        act[k] = std::clamp((float)(a.data<float>()[k] + noise * normal(rng)), -1.0f, 1.0f);
      body.step(act.data(), nullptr);
      double worst = 0;
      sim::tracking_frame_cost(body.data(), h->tracked_bodies(),
                               refs.body_pos.data() + (size_t)refs.global_frame(c, t + 1) * J * 3, &worst);
      if (body.diverged() || !(worst < pd.fail_distance)) break;
    }
  }
  return out;
}

DistillStats fit_actor_to_search(FbAgent& agent, const SearchRows& labels, const SearchRows& anchor,
                                 const DistillOptions& opt, const std::function<void(int64_t, double)>& on_update) {
  const int D = agent.config().obs_dim, d = agent.config().z_dim, A = agent.config().action_dim;
  check_rows(labels, D, d, A, "fit_actor_to_search");
  check_rows(anchor, D, d, A, "fit_actor_to_search");
  if (labels.rows() == 0) throw Error("fit_actor_to_search: no label rows");
  if (opt.updates < 0 || opt.batch < 1 || !(opt.lr > 0) || !(opt.anchor_weight >= 0) ||
      (opt.anchor_weight > 0 && anchor.rows() == 0))
    throw Error("fit_actor_to_search: bad options (updates >= 0, batch >= 1, lr > 0, anchor weight >= 0 with "
                "anchor rows when > 0)");
  DistillStats st;
  {
    ag::NoGradGuard ng;
    st.label_rms_before = rms_to_labels(agent, labels);
    st.anchor_rms_before = rms_to_labels(agent, anchor);
  }
  const Actor& actor = agent.actor();
  nn::AdamWOptions ao;
  ao.lr = opt.lr;
  ao.weight_decay = 0;
  nn::AdamW adam(actor.named_parameters(), ao);
  std::mt19937_64 rng(opt.seed);
  std::vector<int64_t> idx((size_t)opt.batch), idx2((size_t)opt.batch);
  Tensor s, z, a, s2, z2, a2;
  for (int64_t u = 1; u <= opt.updates; ++u) {
    adam.set_lr(opt.lr * 0.5 * (1 + std::cos(M_PI * (double)u / opt.updates)));  // cosine to 0
    for (auto& i : idx) i = (int64_t)(rng() % (uint64_t)labels.rows());
    gather(labels, idx, D, d, A, s, z, a);
    adam.zero_grad();
    ag::Variable loss = nn::mse_loss(actor.forward(ag::Variable(s), ag::Variable(z)), ag::Variable(a));
    if (opt.anchor_weight > 0) {
      for (auto& i : idx2) i = (int64_t)(rng() % (uint64_t)anchor.rows());
      gather(anchor, idx2, D, d, A, s2, z2, a2);
      loss = loss + opt.anchor_weight * nn::mse_loss(actor.forward(ag::Variable(s2), ag::Variable(z2)), ag::Variable(a2));
    }
    loss.backward();
    adam.step();
    if (on_update) on_update(u, (double)loss.data().data<float>()[0]);
  }
  ag::NoGradGuard ng;
  st.label_rms_after = rms_to_labels(agent, labels);
  st.anchor_rms_after = rms_to_labels(agent, anchor);
  return st;
}

}  // namespace t2m::bfm
