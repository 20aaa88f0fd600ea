// fb_agent.cpp — FbAgent: construction (networks, targets, optimizer groups), the FB and actor update steps,
// inference (B, Eq 2, acting, Eq 21) and the training state.
#include "models/bfm/fb_agent.h"

#include <cmath>
#include <string>

#include "autograd/no_grad.h"
#include "autograd/ops_elementwise.h"
#include "autograd/ops_join.h"
#include "models/bfm/actor_loss.h"
#include "models/bfm/fb_loss.h"
#include "models/bfm/fb_networks.h"
#include "models/bfm/fb_optimizer.h"
#include "models/bfm/latent_inference.h"
#include "models/bfm/polyak.h"
#include "models/bfm/sphere_projection.h"
#include "nn/loss_gaussian.h"
#include "tensor/ops.h"

namespace t2m::bfm {

namespace {

void check_mat(const char* what, const Tensor& t, int64_t rows, int64_t cols) {
  if (!t.defined() || t.dim() != 2 || (rows >= 0 && t.size(0) != rows) || t.size(1) != cols ||
      t.dtype() != DType::f32)
    throw Error(std::string("FbAgent: ") + what + " must be f32 [" + (rows >= 0 ? std::to_string(rows) : "N") +
                ", " + std::to_string(cols) + "], got " +
                (t.defined() ? shape_str(t.shape()) + " " + dtype_name(t.dtype()) : std::string("undefined")));
}

std::vector<ag::Variable> params_of(const nn::Module& m) { return m.parameters(); }

void set_requires_grad(const nn::Module& m, bool on) {
  for (const auto& p : m.parameters()) p.set_requires_grad(on);
}

void clear_grads(const nn::Module& m) {
  for (const auto& p : m.parameters()) p.clear_grad();
}

}  // namespace

FbAgent::FbAgent(const FbConfig& cfg, uint64_t seed) : cfg_(cfg) {
  cfg_.validate();
  Generator gen(seed);
  const int D = cfg_.obs_dim, A = cfg_.action_dim, d = cfg_.z_dim, h = cfg_.hidden;
  std::vector<std::string> names;  // "F0", "F1", ...
  for (int e = 0; e < cfg_.ensemble; ++e) names.push_back(std::string(1, 'F').append(std::to_string(e)));
  for (int e = 0; e < cfg_.ensemble; ++e)
    F_.push_back(register_module(names[e], std::make_shared<ForwardMap>(D, A, d, h, gen)));
  B_ = register_module("B", std::make_shared<BackwardMap>(D, d, cfg_.b_hidden, gen));
  actor_ = register_module("actor", std::make_shared<Actor>(D, A, d, h, gen));
  Generator scratch(seed ^ 0x7a26e7ULL);  // targets start as copies; their own init is overwritten
  for (int e = 0; e < cfg_.ensemble; ++e) {
    Ft_.push_back(register_module(names[e] + "_target", std::make_shared<ForwardMap>(D, A, d, h, scratch)));
    polyak_update(params_of(*Ft_[e]), params_of(*F_[e]), 1.0);
    set_requires_grad(*Ft_[e], false);
  }
  Bt_ = register_module("B_target", std::make_shared<BackwardMap>(D, d, cfg_.b_hidden, scratch));
  polyak_update(params_of(*Bt_), params_of(*B_), 1.0);
  set_requires_grad(*Bt_, false);
  // Optimizer: F_e and B in the FB group, the actor in the actor group (names as in named_parameters()).
  nn::NamedParams trained;
  std::vector<int> group;
  for (const auto& [name, v] : named_parameters()) {
    if (name.find("_target.") != std::string::npos) continue;
    trained.emplace_back(name, v);
    group.push_back(name.rfind("actor.", 0) == 0 ? FbOptimizer::kActor : FbOptimizer::kFb);
  }
  opt_ = std::make_unique<FbOptimizer>(trained, group, cfg_.lr_fb, cfg_.lr_actor, cfg_.weight_decay);
}

FbAgent::~FbAgent() = default;

int64_t FbAgent::updates() const { return opt_->step_count(); }

Tensor FbAgent::embed_backward(const Tensor& obs) {
  check_mat("embed_backward obs", obs, -1, cfg_.obs_dim);
  ag::NoGradGuard ng;
  return B_->forward(ag::Variable(obs)).data();
}

Tensor FbAgent::infer_tracking_z(const Tensor& states) { return infer_tracking_z(states, cfg_.track_window); }

// states [T, D] -> B(s_1..s_{T-1}) [T-1, d] -> Eq 2 -> [T-1, d]
Tensor FbAgent::infer_tracking_z(const Tensor& states, int L) {
  check_mat("infer_tracking_z states", states, -1, cfg_.obs_dim);
  if (states.size(0) < 2)
    throw Error("FbAgent: infer_tracking_z needs at least 2 states, got " + shape_str(states.shape()));
  if (L < 1) throw Error("FbAgent: infer_tracking_z window L must be >= 1, got " + std::to_string(L));
  return tracking_latents(embed_backward(states.slice(0, 1, states.size(0))), L);
}

Tensor FbAgent::actor_mean(const Tensor& obs, const Tensor& z) {
  check_mat("actor_mean obs", obs, -1, cfg_.obs_dim);
  check_mat("actor_mean z", z, obs.size(0), cfg_.z_dim);
  ag::NoGradGuard ng;
  return actor_->forward(ag::Variable(obs), ag::Variable(z)).data();
}

void FbAgent::act(const Tensor& obs, const Tensor& z, float noise_std, Generator& gen, Tensor& action) {
  if (!(noise_std >= 0)) throw Error("FbAgent: act noise_std must be >= 0, got " + std::to_string(noise_std));
  const Tensor mu = actor_mean(obs, z);
  Tensor a = mu;
  if (noise_std > 0) a = t2m::clamp(t2m::add(mu, policy_noise(mu.shape(), noise_std, cfg_.actor_clip, gen)), -1, 1);
  if (action.defined() && action.shape() == a.shape() && action.dtype() == a.dtype() && action.is_contiguous())
    action.copy_(a);
  else
    action = a.contiguous();
}

// Eq 21 with a fixed policy std: KL_t = sum_a (mu_hat - mu)^2 / (2 std^2), averaged over the T frames.
double FbAgent::action_kl(const Tensor& states, const Tensor& z_hat, const Tensor& z) {
  const Tensor mu_hat = actor_mean(states, z_hat), mu = actor_mean(states, z);
  const Tensor ls = Tensor::scalar(std::log((double)cfg_.actor_std));
  return nn::action_kl(mu_hat, ls, mu, ls, nn::GaussianScale::log_std);
}

Tensor FbAgent::sample_sphere_z(int n, Generator& gen) {
  if (n < 1) throw Error("FbAgent: sample_sphere_z needs n >= 1, got " + std::to_string(n));
  return project_rows(rand_normal({n, cfg_.z_dim}, gen), std::sqrt((double)cfg_.z_dim));
}

namespace {
// not_done [B] or [B, 1] -> discount * not_done [B]
Tensor discount_vector(const Tensor& not_done, int64_t B, float discount) {
  if (!not_done.defined() || not_done.numel() != B || not_done.dtype() != DType::f32 ||
      !(not_done.dim() == 1 || (not_done.dim() == 2 && not_done.size(1) == 1)))
    throw Error("FbAgent: not_done must be f32 [" + std::to_string(B) + "] or [" + std::to_string(B) + ", 1], got " +
                (not_done.defined() ? shape_str(not_done.shape()) : std::string("undefined")));
  return t2m::mul(not_done.reshape({B}), (double)discount);
}

const Tensor& checked_noise(const char* what, const Tensor& n, int64_t B, int64_t A) {
  check_mat(what, n, B, A);
  return n;
}
}  // namespace

FbUpdateStats FbAgent::update_fb(const FbBatch& b, Generator& gen) {
  const int64_t N = b.obs.defined() ? b.obs.size(0) : 0;
  check_mat("batch obs", b.obs, -1, cfg_.obs_dim);
  if (N < 2) throw Error("FbAgent: the FB loss needs a batch of at least 2 rows, got " + std::to_string(N));
  check_mat("batch action", b.action, N, cfg_.action_dim);
  check_mat("batch next_obs", b.next_obs, N, cfg_.obs_dim);
  check_mat("batch z", b.z, N, cfg_.z_dim);
  const Tensor gamma = discount_vector(b.not_done, N, cfg_.discount);
  const ag::Variable s(b.obs), a(b.action), s2(b.next_obs), z(b.z);
  const Tensor noise = b.next_action_noise.defined()
                           ? checked_noise("next_action_noise", b.next_action_noise, N, cfg_.action_dim)
                           : policy_noise({N, cfg_.action_dim}, cfg_.actor_std, cfg_.actor_clip, gen);
  Tensor tM;
  {  // target successor measure: a' ~ pi(s', z), pess(F_t(s', a', z) B_t(s')^T)
    ag::NoGradGuard ng;
    const ag::Variable s2z = ag::concat({s2, z}, 1);  // joined once for the actor and every member
    const ag::Variable a2 = noisy_action(actor_->forward_joined(s2z, s2), noise);
    const ag::Variable s2a2 = ag::concat({s2, a2}, 1);
    std::vector<ag::Variable> ft;
    for (const auto& f : Ft_) ft.push_back(f->forward_joined(s2z, s2a2));
    tM = pessimistic_target_M(ag::stack(ft, 0).data(), Bt_->forward(s2).data(), cfg_.pessimism);
  }
  for (const auto& f : F_) clear_grads(*f);
  clear_grads(*B_);
  std::vector<ag::Variable> fs;
  const ag::Variable sz = ag::concat({s, z}, 1), sa = ag::concat({s, a}, 1);
  for (const auto& f : F_) fs.push_back(f->forward_joined(sz, sa));
  const ag::Variable Bv = B_->forward(s2);
  FbLossParts td, orth;
  ag::Variable loss = fb_td_loss(ag::stack(fs, 0), Bv, tM, gamma, &td);
  const ag::Variable ol = ortho_loss(Bv, &orth);
  if (cfg_.ortho_coef != 0) loss = loss + ol * (double)cfg_.ortho_coef;
  loss.backward();
  opt_->step_group(FbOptimizer::kFb);
  for (int e = 0; e < cfg_.ensemble; ++e) polyak_update(params_of(*Ft_[e]), params_of(*F_[e]), cfg_.tau);
  polyak_update(params_of(*Bt_), params_of(*B_), cfg_.tau);
  FbUpdateStats st;
  st.fb_loss = (float)loss.item();
  st.ortho_loss = (float)(orth.offdiag + orth.diag);
  st.fb_diag = (float)td.diag;
  st.fb_offdiag = (float)td.offdiag;
  return st;
}

FbUpdateStats FbAgent::update_actor(const FbBatch& b, Generator& gen) {
  const int64_t N = b.obs.defined() ? b.obs.size(0) : 0;
  check_mat("batch obs", b.obs, -1, cfg_.obs_dim);
  check_mat("batch z", b.z, N, cfg_.z_dim);
  const bool bc = b.bc_obs.defined();
  if (bc) {
    check_mat("batch bc_obs", b.bc_obs, -1, cfg_.obs_dim);
    check_mat("batch bc_action", b.bc_action, b.bc_obs.size(0), cfg_.action_dim);
    check_mat("batch bc_z", b.bc_z, b.bc_obs.size(0), cfg_.z_dim);
  }
  const ag::Variable s(b.obs), z(b.z);
  const Tensor noise = b.action_noise.defined()
                           ? checked_noise("action_noise", b.action_noise, N, cfg_.action_dim)
                           : policy_noise({N, cfg_.action_dim}, cfg_.actor_std, cfg_.actor_clip, gen);
  clear_grads(*actor_);
  // F is evaluated but not trained here: no parameter gradient is computed for it (the anchor computes and
  // discards it).
  for (const auto& f : F_) set_requires_grad(*f, false);
  FbUpdateStats st;
  try {
    const ag::Variable sz = ag::concat({s, z}, 1);
    const ag::Variable act = noisy_action(actor_->forward_joined(sz, s), noise);
    const ag::Variable sact = ag::concat({s, act}, 1);
    std::vector<ag::Variable> fs;
    for (const auto& f : F_) fs.push_back(f->forward_joined(sz, sact));
    double qm = 0;
    ag::Variable loss = actor_q_loss(q_values(ag::stack(fs, 0), z), cfg_.pessimism, cfg_.q_normalize, &qm);
    if (bc) {
      const ag::Variable l = bc_loss(actor_->forward(ag::Variable(b.bc_obs), ag::Variable(b.bc_z)), b.bc_action);
      st.bc_loss = (float)l.item();
      if (cfg_.bc_coef != 0) loss = loss + l * (double)cfg_.bc_coef;
    }
    loss.backward();
    st.actor_loss = (float)loss.item();
    st.q_mean = (float)qm;
  } catch (...) {
    for (const auto& f : F_) set_requires_grad(*f, true);
    throw;
  }
  for (const auto& f : F_) set_requires_grad(*f, true);
  opt_->step_group(FbOptimizer::kActor);
  return st;
}

FbUpdateStats FbAgent::update(const FbBatch& b, Generator& gen) {
  FbUpdateStats st = update_fb(b, gen);
  const FbUpdateStats sa = update_actor(b, gen);
  st.actor_loss = sa.actor_loss;
  st.bc_loss = sa.bc_loss;
  st.q_mean = sa.q_mean;
  opt_->finish_step();
  return st;
}

nn::TrainState FbAgent::train_state(const nlohmann::json& run_config) {
  nn::TrainState ts(named_parameters(), {{"fb", cfg_.to_json()}, {"run", run_config}});
  ts.optimizer(*opt_);
  ts.step = updates();
  return ts;
}

void FbAgent::save(const std::string& path) { train_state().save(path); }

void FbAgent::load(const std::string& path) {
  nn::TrainState ts = train_state();
  try {
    ts.load(path);
  } catch (const Error& e) {
    throw Error(std::string("FbAgent: ") + e.what());
  }
}

}  // namespace t2m::bfm
