// vbb_loss.cpp — Eq 5, 6, 7–12 and 13 of Text2BFM composed from the nn losses (mse_loss, kl_diag_gaussians,
// kl_standard_normal, frame_token_contrastive_loss); this file only checks shapes, applies masks and weights.
#include "models/text2bfm/vbb_loss.h"

#include <string>

#include "autograd/no_grad.h"
#include "autograd/ops_elementwise.h"
#include "nn/loss_gaussian.h"
#include "nn/loss_reduce.h"
#include "nn/loss_regression.h"

namespace t2m::text2bfm {
namespace {

[[noreturn]] void fail(const std::string& what) { throw Error("vbb_loss: " + what); }

std::string str(const Tensor& t) { return t.defined() ? shape_str(t.shape()) : std::string("undefined"); }

}  // namespace

// Text2BFM Eq 5: (1/Tz) Σ_t ||z_t − ẑ_t||² + λπ (1/Tz) Σ_t KL(π(·|s_t, ẑ_t) || π(·|s_t, z_t))
VbbReconstruction vbb_reconstruction_loss(const ag::Variable& z_hat, const Tensor& z, const Tensor& states,
                                          const FrozenActor& actor, double lambda_pi, const Tensor& frame_mask) {
  if (!z_hat.defined() || z_hat.dim() != 3) fail("z_hat must be (B, Tz, d), got " + str(z_hat.data()));
  if (!z.defined() || z.shape() != z_hat.shape())
    fail("z " + str(z) + " must have z_hat's shape " + shape_str(z_hat.shape()));
  if (!(lambda_pi >= 0.0)) fail("lambda_pi must be >= 0, got " + std::to_string(lambda_pi));
  const int64_t B = z_hat.size(0), Tz = z_hat.size(1);
  Tensor w;  // (B, Tz) 0/1 frame weights or undefined
  if (frame_mask.defined()) w = nn::valid_mask(frame_mask, {B, Tz}, z_hat.dtype(), "vbb_loss", "frame_mask");

  nn::MseOptions mo;
  mo.sum_last_dim = true;
  if (w.defined()) mo.weights = w.reshape({B, Tz, 1});
  VbbReconstruction r;
  r.latent_mse = nn::mse_loss(z_hat, ag::Variable(z.to(z_hat.dtype())), mo);
  r.loss = r.latent_mse;
  if (!actor || lambda_pi == 0.0) return r;

  if (!states.defined() || states.dim() != 3 || states.size(0) != B || states.size(1) != Tz)
    fail("states must be (" + std::to_string(B) + ", " + std::to_string(Tz) + ", S), got " + str(states));
  ag::Variable s(states.to(z_hat.dtype()));
  ActorGaussian ref;
  {
    ag::NoGradGuard no_grad;  // π(·|s_t, z_t): the fixed reference distribution
    ref = actor(s, ag::Variable(z.to(z_hat.dtype())));
  }
  ActorGaussian rec = actor(s, z_hat);
  if (!rec.mean.defined() || !ref.mean.defined() || rec.mean.dim() != 3 || rec.mean.size(0) != B ||
      rec.mean.size(1) != Tz || ref.mean.shape() != rec.mean.shape())
    fail("the actor must return a (B, Tz, A) mean for both latents, got " + str(rec.mean.data()) + " and " +
         str(ref.mean.data()));
  ag::Variable kl = nn::kl_diag_gaussians(rec.mean, rec.log_std, ref.mean.detach(), ref.log_std.detach());  // (B, Tz)
  r.action_kl = nn::weighted_mean(kl, w, "vbb_loss");
  r.loss = ag::add(r.latent_mse, ag::mul(r.action_kl, lambda_pi));
  return r;
}

// Text2BFM Eq 6: KL(q_φ(m | z) || N(0, I)), mean over the (unmasked) elements.
ag::Variable vbb_prior_kl(const ag::Variable& mu, const ag::Variable& logvar, const Tensor& program_mask) {
  if (!mu.defined() || mu.dim() != 3) fail("mu must be (B, latent, Tm), got " + str(mu.data()));
  Tensor w;
  if (program_mask.defined())
    w = nn::valid_mask(program_mask, {mu.size(0), mu.size(2)}, mu.dtype(), "vbb_loss", "program_mask")
            .reshape({mu.size(0), 1, mu.size(2)});
  return nn::kl_standard_normal(mu, logvar, nn::KlReduction::mean_elements, w);
}

// Text2BFM Eq 7–12: frame-token contrastive loss between P_m(m) and P_y(y).
nn::ContrastiveLoss vbb_semantic_loss(const VbbSemanticHead& head, const ag::Variable& m, const Tensor& program_mask,
                                      const Tensor& tokens, const Tensor& token_mask,
                                      const nn::FrameTokenOptions& opt) {
  if (!tokens.defined()) fail("the semantic loss needs token features");
  ag::Variable pm = head.project_program(m);                                  // (B, Tm, D)
  ag::Variable py = head.project_tokens(ag::Variable(tokens.to(m.dtype())));  // (B, K, D)
  return nn::frame_token_contrastive_loss(pm, program_mask, py, token_mask, head.alpha(), opt);
}

// Text2BFM Eq 13: L_VBB = L_rec + β L_KL + λsem L_sem.
VbbLossTerms vbb_loss(const VbbOutput& out, const VbbTargets& batch, const FrozenActor& actor,
                      const VbbSemanticHead* head, const VbbLossOptions& opt) {
  if (!(opt.beta >= 0.0) || !(opt.lambda_sem >= 0.0))
    fail("beta and lambda_sem must be >= 0, got " + std::to_string(opt.beta) + ", " + std::to_string(opt.lambda_sem));
  VbbLossTerms t;
  t.rec = vbb_reconstruction_loss(out.z_hat, batch.z, batch.states, actor, opt.lambda_pi, batch.frame_mask);
  t.kl = vbb_prior_kl(out.mu, out.logvar, batch.program_mask);
  t.total = ag::add(t.rec.loss, ag::mul(t.kl, opt.beta));
  if (head && opt.lambda_sem > 0.0) {
    t.sem = vbb_semantic_loss(*head, out.m, batch.program_mask, batch.tokens, batch.token_mask, opt.frame_token).loss;
    t.total = ag::add(t.total, ag::mul(t.sem, opt.lambda_sem));
  }
  return t;
}

Tensor program_mask_from_frames(const Tensor& frame_mask, int64_t compression) {
  if (!frame_mask.defined() || frame_mask.dim() != 2) fail("frame_mask must be (B, Tz), got " + str(frame_mask));
  if (compression < 1 || frame_mask.size(1) % compression != 0)
    fail("Tz = " + std::to_string(frame_mask.size(1)) + " is not a multiple of the compression " +
         std::to_string(compression));
  const int64_t B = frame_mask.size(0), Tm = frame_mask.size(1) / compression;
  return nn::valid_mask(frame_mask.slice(1, 0, frame_mask.size(1), compression).contiguous(), {B, Tm}, DType::f32,
                        "vbb_loss", "frame_mask");
}

}  // namespace t2m::text2bfm
