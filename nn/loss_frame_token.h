// loss_frame_token.h — the motion-text frame-token contrastive loss of Text2BFM (Eq 7–12).
//
// Inputs: motion frame features P_m(m_{i,t}) as motion (Bm, Tm, D) with motion_mask (Bm, Tm), and the frozen
// text encoder's projected token features P_y(y_{j,k}) as text (Bt, K, D) with text_mask (Bt, K). Masks are
// key-padding masks of any dtype: nonzero = valid frame/token, 0 = padding; undefined = all valid. Every clip
// needs >= 1 valid frame and every caption >= 1 valid token. Padded rows must be finite; they change neither the
// result nor get gradient.
//
// frame_token_similarity(...) -> R (Bm, Bt), gradients to motion and text:
//   Eq 7:  m̃_{i,t} = m_{i,t} / max(||m_{i,t}||, 1e-12), ỹ_{j,k} likewise (skipped when normalize = false)
//   Eq 8:  F_{ijt} = λtok · log( (1/K_j) Σ_{valid k} exp(m̃_{i,t}·ỹ_{j,k} / λtok) )
//          = λtok · (logsumexp_k(S/λtok) − log K_j), K_j = valid tokens of caption j (log-mean-exp, stable)
//   Eq 9:  w_{ijt} = softmax over the valid frames t of motion i of F_{ijt} / λfrm
//   Eq 10: R_{ij}  = Σ_t w_{ijt} F_{ijt}
//   λtok and λfrm are temperatures (sharpness of token pooling and of frame weighting): λ → 0 tends to the max,
//   λ → ∞ to the mean. The paper does not give their values; the defaults 0.1 / 0.1 are our choice.
//
// frame_token_contrastive_loss(...) -> ContrastiveLoss (nn/loss_contrastive.h) with Bm = Bt = B:
//   Eq 11–12 on logits γ R with γ = logit_scale_gamma(alpha) = exp(clamp(α, 0, ln 100)) (CLIP's clamp); alpha is
//   the learnable parameter (one element) and receives a gradient. opt.text_ids (int64 (B,)) removes false
//   negatives sharing a caption id, as in symmetric_contrastive. L_sem of Eq 12 is result.loss.
//
// Cost: one (Bm·Tm, D)×(D, Bt·K) product (the dominant FLOPs) and two (Bm, Tm, Bt, K) tensors (S, kept for the
// backward of the fused token pooling, and its gradient; B = 64, Tm = 25, K = 24 ->
// 2.5M elements each).
// Errors ("frame_token: ..."): motion/text not 3-D or D differs, dtypes differ or not float, mask shapes wrong,
// a clip/caption with no valid entry (names which), λ <= 0, alpha not one element, Bm != Bt for the loss.
#pragma once
#include "autograd/variable.h"
#include "nn/loss_contrastive.h"

namespace t2m::nn {

struct FrameTokenOptions {
  double lambda_tok = 0.1;  // Eq 8 token-pooling temperature
  double lambda_frm = 0.1;  // Eq 9 frame-weighting temperature
  bool normalize = true;    // Eq 7 L2 normalisation inside (false: features are already unit vectors)
  Tensor text_ids;          // optional int64 (B,) caption ids for false-negative exclusion (loss only)
};

ag::Variable frame_token_similarity(const ag::Variable& motion, const Tensor& motion_mask, const ag::Variable& text,
                                    const Tensor& text_mask, const FrameTokenOptions& opt = {});

ContrastiveLoss frame_token_contrastive_loss(const ag::Variable& motion, const Tensor& motion_mask,
                                             const ag::Variable& text, const Tensor& text_mask,
                                             const ag::Variable& alpha, const FrameTokenOptions& opt = {});

}  // namespace t2m::nn
