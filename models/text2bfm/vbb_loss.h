// vbb_loss.h — the VBB training objective of Text2BFM (Eq 5, 6, 7–12 and their sum, Eq 13).
//
// Frozen actor: the BFM's π(a | s, z) enters Eq 5 as a callable FrozenActor(states, z) -> ActorGaussian
//   {mean (B, T, A), log_std broadcastable to it}, so the loss works before the BFM exists (tests use a linear toy
//   actor). Its parameters must not require grad (they are frozen: if they did, they would collect gradients that
//   no VBB optimizer steps). The reference side π(·|s_t, z_t) is evaluated without a graph; gradients reach ẑ only.
//
// vbb_reconstruction_loss — Eq 5:
//   L_rec = (1/Tz) Σ_t ||z_t − ẑ_t||² + λπ (1/Tz) Σ_t KL(π(·|s_t, ẑ_t) || π(·|s_t, z_t))
//   z_hat (B, Tz, d) (graph), z (B, Tz, d) and states (B, Tz, S) data. With a frame mask (B, Tz) (nonzero = real
//   frame) both means run over the real frames of the batch (padding changes nothing and gets no gradient).
//   The KL term is skipped (action_kl undefined) when the actor is empty or λπ = 0.
// vbb_prior_kl — Eq 6: KL(q_φ(m | z) || N(0, I)) with nn::kl_standard_normal's mean over elements (the anchor's
//   scale, for which β = 1e-4 is set); program_mask (B, Tm) drops padded program frames.
// vbb_semantic_loss — Eq 7–12: nn::frame_token_contrastive_loss between head.project_program(m) (B, Tm, D) and
//   head.project_tokens(tokens) (B, K, D), with head.alpha() as the logit scale. m is the sampled program (the
//   paper's "compact program m_i"); tokens are the frozen text encoder's features (data).
// vbb_loss — Eq 13: L_VBB = L_rec + β L_KL + λsem L_sem, λπ 0.1, β 1e-4, λsem 0.35 (paper Table 6). The semantic
//   term is skipped when head is null or λsem = 0 (the "VBB without L_sem" ablation).
// program_mask_from_frames(frame_mask (B, Tz), c) -> (B, Tz / c) float32: program frame j is real iff latent
//   frame j·c is (it then summarises at least one real frame).
// Errors (t2m::Error "vbb_loss: ..."): shapes that do not match (names them), Tz not a multiple of c, negative
//   weights, an actor returning the wrong shapes; plus those of the nn losses.
#pragma once
#include <functional>

#include "autograd/variable.h"
#include "models/text2bfm/vbb.h"
#include "models/text2bfm/vbb_semantic_head.h"
#include "nn/loss_contrastive.h"
#include "nn/loss_frame_token.h"

namespace t2m::text2bfm {

struct ActorGaussian {
  ag::Variable mean;     // (B, T, A)
  ag::Variable log_std;  // broadcastable to mean
};
using FrozenActor = std::function<ActorGaussian(const ag::Variable& states, const ag::Variable& z)>;

struct VbbLossOptions {
  double lambda_pi = 0.1;    // Eq 5
  double beta = 1e-4;        // Eq 13
  double lambda_sem = 0.35;  // Eq 13
  nn::FrameTokenOptions frame_token;  // λtok, λfrm (Eq 8–9), caption ids
};

struct VbbReconstruction {
  ag::Variable latent_mse;  // (1/Tz) Σ ||z − ẑ||²
  ag::Variable action_kl;   // (1/Tz) Σ KL(π(·|s, ẑ) || π(·|s, z)); undefined when skipped
  ag::Variable loss;        // latent_mse + λπ action_kl
};

// What a VBB batch holds besides the model output (all data, no gradient).
struct VbbTargets {
  Tensor z;             // (B, Tz, d) policy latents (Eq 2)
  Tensor states;        // (B, Tz, S) the clip's states s_t (only needed with an actor)
  Tensor frame_mask;    // (B, Tz) or undefined
  Tensor program_mask;  // (B, Tm) or undefined
  Tensor tokens;        // (B, K, text_dim) frozen token features (only needed with a head)
  Tensor token_mask;    // (B, K) or undefined
};

struct VbbLossTerms {
  ag::Variable total;  // Eq 13
  VbbReconstruction rec;
  ag::Variable kl;     // Eq 6
  ag::Variable sem;    // Eq 12, undefined when skipped
};

// Text2BFM Eq 5.
VbbReconstruction vbb_reconstruction_loss(const ag::Variable& z_hat, const Tensor& z, const Tensor& states,
                                          const FrozenActor& actor, double lambda_pi,
                                          const Tensor& frame_mask = Tensor());
// Text2BFM Eq 6.
ag::Variable vbb_prior_kl(const ag::Variable& mu, const ag::Variable& logvar, const Tensor& program_mask = Tensor());
// Text2BFM Eq 7–12.
nn::ContrastiveLoss vbb_semantic_loss(const VbbSemanticHead& head, const ag::Variable& m, const Tensor& program_mask,
                                      const Tensor& tokens, const Tensor& token_mask,
                                      const nn::FrameTokenOptions& opt = {});
// Text2BFM Eq 13.
VbbLossTerms vbb_loss(const VbbOutput& out, const VbbTargets& batch, const FrozenActor& actor,
                      const VbbSemanticHead* head, const VbbLossOptions& opt = {});

Tensor program_mask_from_frames(const Tensor& frame_mask, int64_t compression);

}  // namespace t2m::text2bfm
