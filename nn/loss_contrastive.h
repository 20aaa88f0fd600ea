// loss_contrastive.h — symmetric contrastive (CLIP / TMR InfoNCE) losses over a batch of B matched pairs, the
// learnable logit scale, and the Eq 11–12 reduction shared with the frame-token loss (nn/loss_frame_token.h).
//
// Logit scale (Eq 11: γ = exp(α), α learnable): logit_scale_gamma(alpha) = exp(clamp(α, 0, ln 100)), so
//   γ ∈ [1, 100] like CLIP's. alpha: a Variable with one element (0-d or [1]); float dtype of the logits. The
//   clamp is part of the forward: outside [0, ln 100] α gets no gradient, so also call clamp_logit_scale_(α)
//   after each optimizer step (what CLIP does in place), which keeps α inside where the gradient flows.
//   Initial value: kInitLogitScale = ln(1 / 0.07) (CLIP).
//
// symmetric_contrastive(logits, text_ids) — Eq 11–12 on a (B, B) logits matrix L with L[i][j] = γ R(motion i,
//   text j) and the matched pairs on the diagonal:
//     motion_to_text = (1/B) sum_i [ logsumexp_j L[i][j] - L[i][i] ]     (L_{m→Y})
//     text_to_motion = (1/B) sum_j [ logsumexp_i L[i][j] - L[j][j] ]     (L_{Y→m})
//     loss = (motion_to_text + text_to_motion) / 2                        (Eq 12)
//   logsumexp subtracts the max, so logits of any size give finite values. text_ids: undefined, or an int64
//   (B,) tensor of caption ids; then off-diagonal entries (i, j) with text_ids[i] == text_ids[j] are false
//   negatives (the same caption paired with another clip) and are left out of both denominators (TMR-style
//   filtering, with id equality instead of a text-similarity threshold). Without exclusion, equal logits give
//   loss = log B; a diagonal that exceeds every off-diagonal entry by a wide margin gives ~0.
//   Errors ("symmetric_contrastive: ..."): logits not (B, B) with B >= 1, non-float logits, text_ids not int64 (B,).
//
// info_nce(motion, text, alpha, text_ids, normalize) — TMR/CLIP InfoNCE on pooled embeddings: motion (B, D) and
//   text (B, D) are L2-normalised along D (x / max(||x||, 1e-12), like F.normalize; skip with normalize =
//   false), logits = γ · motion text^T (cosine similarities times γ), then symmetric_contrastive. A fixed
//   temperature τ is alpha = log(1/τ) as a Variable that does not require grad (TMR: τ = 0.1).
//   Errors ("info_nce: ..."): not 2-D, B or D differ, dtypes differ, alpha not one element.
#pragma once
#include <cmath>

#include "autograd/variable.h"

namespace t2m::nn {

inline const double kMaxLogitScale = std::log(100.0);  // upper clamp of α (γ <= 100)
inline const double kInitLogitScale = std::log(1.0 / 0.07);

struct ContrastiveLoss {
  ag::Variable loss;            // Eq 12: (motion_to_text + text_to_motion) / 2
  ag::Variable motion_to_text;  // L_{m→Y} of Eq 11
  ag::Variable text_to_motion;  // L_{Y→m} of Eq 11
  ag::Variable logits;          // (B, B) γ-scaled logits, rows = motions, columns = texts (before exclusion)
};

// γ = exp(clamp(α, 0, ln 100)), a one-element Variable of alpha's shape.
ag::Variable logit_scale_gamma(const ag::Variable& alpha, const char* op = "logit_scale_gamma");
// In place: α.data() clamped to [0, ln 100] (no graph). Error when alpha is not a one-element float leaf.
void clamp_logit_scale_(const ag::Variable& alpha);

ContrastiveLoss symmetric_contrastive(const ag::Variable& logits, const Tensor& text_ids = Tensor());

// x (..., D) / max(||x||_2 along D, eps) — Eq 7's normalisation. A zero vector stays zero; its gradient is the
// incoming one times 1/eps (finite; zero for padded rows, whose incoming gradient is zero).
ag::Variable l2_normalize(const ag::Variable& x, double eps = 1e-12);

ContrastiveLoss info_nce(const ag::Variable& motion, const ag::Variable& text, const ag::Variable& alpha,
                         const Tensor& text_ids = Tensor(), bool normalize = true);

}  // namespace t2m::nn
