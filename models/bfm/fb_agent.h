// fb_agent.h — the behavior foundation model: a forward-backward (FB) agent in the Meta Motivo recipe
// (ARCHITECTURE.md section 5; Text2BFM Eq 1-2, Eq 21). The public API other parts build on (t2m train bfm,
// t2m eval track, Text2BFM latent extraction). This header is the contract; it stays stable.
//
// Networks (children, in registration order; parameter names "F0.embed_z.0.weight", ...):
//   F0, F1, ...   forward maps F_e(s, a, z) -> R^d, `ensemble` members          (models/bfm/forward_map.h)
//   B             backward map B(s) -> z on the sphere of radius sqrt(d)          (models/bfm/backward_map.h)
//   actor         pi(a | s, z): Gaussian, mean tanh-squashed, fixed std          (models/bfm/actor.h)
//   F0_target, F1_target, ..., B_target: Polyak-averaged copies (tau), not trained (requires_grad = false).
// named_parameters() therefore lists targets too, so a TrainState built from it saves and restores them.
//
// One update (update()): the FB step then the actor step, as in Meta Motivo's FB agent:
//   FB step (models/bfm/fb_loss.h): a' = clamp(mu(s', z) + clip(N(0, std^2), +-clip), -1, 1) from the actor (no grad);
//     M_e = F_e(s, a, z) B(s')^T [B, B];  target M = pess(F_t(s', a', z) B_t(s')^T);  diff = M_e - discount
//     not_done_i tM;  L_fb = sum_e [ 0.5 mean_{i != j} diff_eij^2 - mean_i diff_eii ]
//     + ortho_coef * (0.5 mean_{i != j} C_ij^2 - mean_i C_ii),  C = B(s') B(s')^T
//     -> AdamW on F and B (lr_fb) -> Polyak  theta_t <- (1 - tau) theta_t + tau theta  on every F and B.
//   actor step (models/bfm/actor_loss.h): a = clamp(mu(s, z) + noise, -1, 1) (reparametrised);
//     Q = pess(F_e(s, a, z)^T z);  L_actor = -mean(Q) / (q_normalize ? mean|Q| (no grad) : 1)
//     + bc_coef * mean((mu(s_bc, z_bc) - a_bc)^2)   (behaviour cloning on data actions, TD3+BC style; only when
//     the batch carries bc_obs) -> AdamW on the actor (lr_actor). F gets no parameter gradient here.
//   pess over the ensemble: mean_e x_e - pessimism * (mean over pairs e < e' of |x_e - x_e'|) / 2
//     (= mean - 0.5 |x_0 - x_1| / 2 for 2 members and pessimism 0.5, the anchor's formula).
// With bc_coef = 0 and q_normalize = false the losses are exactly those of ../shared/anchor/torch_ref.py (fb).
//
// Shapes: N = any number of rows, B = batch, d = z_dim, D = obs_dim, A = action_dim, T = clip length. float32.
// Determinism: every random draw comes from the Generator passed in (Philox), so a seed and a thread count fix
// every bit of an update sequence.
//
// Saving and resuming: train_state() returns an nn::TrainState over all parameters (incl. targets) and the
// agent's optimizer state; callers add generators / set step and call save(path) / load(path) (atomic, CRC
// checked; load validates everything first and changes nothing on error). save()/load() below are the
// agent-only shorthand (e.g. for shipped checkpoints and tests).
//
// Errors (t2m::Error, message starts "FbAgent: "): bad config values (dims < 1, ensemble < 1, discount/tau
// outside [0, 1], negative coefficients); input shapes that do not match the config (the message names the
// argument and both shapes); infer_tracking_z on fewer than 2 states or L < 1; a FbBatch with bc_obs but no
// bc_action / bc_z; a checkpoint of another config.
#pragma once
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "nn/module.h"
#include "nn/train_state.h"
#include "tensor/rng.h"
#include "tensor/tensor.h"

namespace t2m::bfm {

class ForwardMap;
class BackwardMap;
class Actor;
class FbOptimizer;

struct FbConfig {
  int obs_dim = 313;      // sim/observation.h: observation_dim(21)
  int action_dim = 60;    // 20 bodies x 3 hinges
  int z_dim = 64;         // d
  int hidden = 256;       // width of F and the actor (the anchor's h)
  int b_hidden = 256;     // width of B (the anchor keeps 256 for every h)
  int ensemble = 2;       // members of F
  float discount = 0.98f;
  float tau = 0.01f;          // Polyak rate of the target networks
  float ortho_coef = 1.f;     // orthonormality regularizer on B
  float pessimism = 0.5f;     // ensemble penalty (see pess above)
  float bc_coef = 0.4f;       // behaviour-cloning weight (TD3+BC's alpha = 2.5 <=> 1 / 2.5)
  bool q_normalize = true;    // divide -Q by mean|Q| (no grad) so bc_coef is scale-free (TD3+BC)
  float actor_std = 0.2f;     // policy std (fixed, Meta Motivo)
  float actor_clip = 0.3f;    // noise clip in training samples
  float lr_fb = 1e-4f;
  float lr_actor = 1e-4f;
  float weight_decay = 0.f;   // AdamW decoupled weight decay for all trained parameters
  int track_window = 8;       // L of Eq 2

  nlohmann::json to_json() const;
  static FbConfig from_json(const nlohmann::json& j);  // missing keys keep defaults; unknown keys: Error
  void validate() const;                                // throws on bad values
};

// One update's inputs. Rows i of obs/action/next_obs/not_done/z belong together.
struct FbBatch {
  Tensor obs;        // [B, D]
  Tensor action;     // [B, A]   in [-1, 1]
  Tensor next_obs;   // [B, D]
  Tensor not_done;   // [B] or [B, 1]   1 = s' continues, 0 = terminal (masks the bootstrap)
  Tensor z;          // [B, d]   on the sphere (sample_sphere_z, B of states, or Eq 2 windows)
  // Optional data batch for the behaviour-cloning term (undefined bc_obs = no BC term this update).
  Tensor bc_obs;     // [Bc, D]
  Tensor bc_action;  // [Bc, A]
  Tensor bc_z;       // [Bc, d]  the latent that explains the data action (e.g. Eq 2 on its reference window)
  // Optional fixed policy noise (tests, PyTorch parity): when defined it replaces the draw from the Generator
  // (already std-scaled and clipped), and the Generator is not advanced for it.
  Tensor next_action_noise;  // [B, A]  FB step: a' = clamp(mu(s', z) + noise, -1, 1)
  Tensor action_noise;       // [B, A]  actor step: a = clamp(mu(s, z) + noise, -1, 1)
};

struct FbUpdateStats {
  float fb_loss = 0;     // L_fb incl. the ortho term (what the FB optimizer minimised)
  float ortho_loss = 0;  // orthonormality term (unweighted)
  float actor_loss = 0;  // full actor objective
  float bc_loss = 0;     // BC mean squared error (unweighted; 0 without bc data)
  float q_mean = 0;      // mean pessimistic Q of the actor step
  float fb_diag = 0;     // -mean diag(diff) summed over members (diagnostic)
  float fb_offdiag = 0;  // off-diagonal TD term summed over members (diagnostic)
};

class FbAgent : public nn::Module {
 public:
  FbAgent(const FbConfig& cfg, uint64_t seed);
  ~FbAgent() override;
  const FbConfig& config() const { return cfg_; }

  // B(s), no graph: [N, D] -> [N, d], each row of norm sqrt(d).
  Tensor embed_backward(const Tensor& obs);
  // Text2BFM Eq 2: z_t = Proj(1/H_t sum_{k<H_t} B(s_{t+1+k})), H_t = min(L, T-1-t) (0-based t), L = track_window.
  // states [T, D] (T >= 2) -> [T-1, d]: one latent per transition (T_z = T - 1, no latent after the last state).
  Tensor infer_tracking_z(const Tensor& states);
  Tensor infer_tracking_z(const Tensor& states, int L);
  // Policy mean mu(s, z) = tanh(...), no graph: [N, D], [N, d] -> [N, A].
  Tensor actor_mean(const Tensor& obs, const Tensor& z);
  // Action for acting in the environment, no graph: action = clamp(mu + clamp(noise_std * eps, +-actor_clip),
  // -1, 1), eps ~ N(0, 1) from gen (noise_std = 0: the mean, gen untouched). action is (re)allocated to [N, A]
  // unless it already has that shape (then written in place).
  void act(const Tensor& obs, const Tensor& z, float noise_std, Generator& gen, Tensor& action);
  // Text2BFM Eq 21: mean over frames of KL(pi(.|s_t, z_hat_t) || pi(.|s_t, z_t)); the policy std is fixed, so
  // per frame KL = sum_a (mu_hat - mu)^2 / (2 std^2). states [T, D], z_hat, z [T, d].
  double action_kl(const Tensor& states, const Tensor& z_hat, const Tensor& z);

  // One FB step and one actor step (optimizers and Polyak included). Draws the actor noise from gen.
  FbUpdateStats update(const FbBatch& batch, Generator& gen);
  // The two halves separately (benchmarks, tests): update() = update_fb(), update_actor(), then the update
  // count (AdamW's bias-correction step t) advances by one. The halves alone use t = updates() + 1 and do not
  // advance it. Call update() in training.
  FbUpdateStats update_fb(const FbBatch& batch, Generator& gen);
  FbUpdateStats update_actor(const FbBatch& batch, Generator& gen);

  // n random latents uniform on the sphere of radius sqrt(d): [n, d].
  Tensor sample_sphere_z(int n, Generator& gen);

  // Full training state (all parameters incl. targets + optimizer moments + update count) as a TrainState;
  // config recorded = {"fb": config().to_json(), "run": run_config}. The TrainState refers to this agent.
  nn::TrainState train_state(const nlohmann::json& run_config = nlohmann::json::object());
  void save(const std::string& path);   // train_state().save(path)
  void load(const std::string& path);   // train_state().load(path); Error on another config
  int64_t updates() const;              // completed update() calls (the optimizer step count)

  // Parts (read access for tests, parity and tools).
  const ForwardMap& forward_map(int e) const { return *F_.at(e); }
  const ForwardMap& forward_target(int e) const { return *Ft_.at(e); }
  const BackwardMap& backward_map() const { return *B_; }
  const BackwardMap& backward_target() const { return *Bt_; }
  const Actor& actor() const { return *actor_; }
  FbOptimizer& optimizer() { return *opt_; }

 private:
  FbConfig cfg_;
  std::vector<std::shared_ptr<ForwardMap>> F_, Ft_;
  std::shared_ptr<BackwardMap> B_, Bt_;
  std::shared_ptr<Actor> actor_;
  std::unique_ptr<FbOptimizer> opt_;
};

}  // namespace t2m::bfm
