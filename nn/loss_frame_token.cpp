// loss_frame_token.cpp — Eq 7–12 from autograd ops plus the fused token pooling (nn/loss_token_pool.h). Layout:
// the (Bm·Tm, Bt·K) score product viewed as (Bm·Tm, Bt, K), so the token pooling reduces the last dim and the
// frame weighting dim 1 of F (Bm, Tm, Bt), without any permute.
#include "nn/loss_frame_token.h"

#include <cmath>
#include <limits>
#include <string>

#include "autograd/ops_elementwise.h"
#include "autograd/ops_linalg.h"
#include "autograd/ops_reduce.h"
#include "autograd/ops_shape.h"
#include "autograd/ops_softmax.h"
#include "nn/loss_reduce.h"
#include "nn/loss_token_pool.h"
#include "tensor/ops.h"

namespace t2m::nn {
namespace {

constexpr const char* kOp = "frame_token";
constexpr double kNegInf = -std::numeric_limits<double>::infinity();

// 0/1 validity mask (rows, cols) in dtype; all ones when undefined. Every row needs a valid entry.
Tensor checked_mask(const Tensor& mask, int64_t rows, int64_t cols, DType dtype, const char* what) {
  if (!mask.defined()) return Tensor::ones({rows, cols}, dtype);
  Tensor m = valid_mask(mask, {rows, cols}, dtype, kOp, what);
  const Tensor counts = t2m::sum(m.to(DType::f64), {1});
  for (int64_t r = 0; r < rows; ++r)
    if (counts.at({r}) == 0.0)
      throw Error(std::string(kOp) + ": " + what + " row " + std::to_string(r) + " has no valid entry");
  return m;
}

}  // namespace

// motion (Bm, Tm, D), text (Bt, K, D) -> R (Bm, Bt)   (Eq 7–10)
ag::Variable frame_token_similarity(const ag::Variable& motion, const Tensor& motion_mask, const ag::Variable& text,
                                    const Tensor& text_mask, const FrameTokenOptions& opt) {
  if (!motion.defined() || !text.defined()) throw Error(std::string(kOp) + ": motion or text is undefined");
  if (motion.dim() != 3 || text.dim() != 3 || motion.size(2) != text.size(2))
    throw Error(std::string(kOp) + ": motion must be (Bm, Tm, D) and text (Bt, K, D) with one D, got " +
                shape_str(motion.shape()) + " and " + shape_str(text.shape()));
  const DType dt = motion.dtype();
  if (dt != text.dtype() || (dt != DType::f32 && dt != DType::f64))
    throw Error(std::string(kOp) + ": motion and text must share a float dtype, got " + dtype_name(dt) + " and " +
                dtype_name(text.dtype()));
  if (!(opt.lambda_tok > 0.0) || !(opt.lambda_frm > 0.0))
    throw Error(std::string(kOp) + ": lambda_tok and lambda_frm must be > 0, got " + std::to_string(opt.lambda_tok) +
                " and " + std::to_string(opt.lambda_frm));
  const int64_t Bm = motion.size(0), Tm = motion.size(1), Bt = text.size(0), K = text.size(1), D = motion.size(2);
  if (Bm < 1 || Tm < 1 || Bt < 1 || K < 1 || D < 1)
    throw Error(std::string(kOp) + ": empty motion or text: " + shape_str(motion.shape()) + " and " +
                shape_str(text.shape()));
  const Tensor mvalid = checked_mask(motion_mask, Bm, Tm, dt, "motion_mask");  // (Bm, Tm)
  const Tensor tvalid = checked_mask(text_mask, Bt, K, dt, "text_mask");       // (Bt, K)

  // Eq 7 (the 1/λtok of Eq 8 folded into the motion side: Bm·Tm·D multiplies instead of Bm·Tm·Bt·K)
  ag::Variable m = opt.normalize ? l2_normalize(motion) : motion;
  ag::Variable y = opt.normalize ? l2_normalize(text) : text;
  m = ag::mul(m, 1.0 / opt.lambda_tok);
  // S/λtok: (Bm·Tm, D) × (Bt·K, D)^T -> (Bm·Tm, Bt, K)
  ag::Variable s = ag::matmul_t(m.reshape({Bm * Tm, D}), false, y.reshape({Bt * K, D}), true).view({Bm * Tm, Bt, K});
  // Eq 8: λtok · log-mean-exp over the valid tokens (fused, nn/loss_token_pool.h)
  ag::Variable f = ag::mul(masked_log_mean_exp(s, tvalid).view({Bm, Tm, Bt}), opt.lambda_tok);  // (Bm, Tm, Bt)
  // Eq 9: softmax over the valid frames of F/λfrm
  const Tensor frm_pad = t2m::eq(mvalid, Tensor::zeros({}, dt)).view({Bm, Tm, 1});
  ag::Variable w = ag::softmax(ag::masked_fill(ag::mul(f, 1.0 / opt.lambda_frm), frm_pad, kNegInf), 1);
  // Eq 10: R = Σ_t w F  (padded frames: w = 0 and F zeroed, so no 0·garbage)
  return ag::sum(ag::mul(w, ag::masked_fill(f, frm_pad, 0.0)), {1});  // (Bm, Bt)
}

// Eq 11–12 on γ R
ContrastiveLoss frame_token_contrastive_loss(const ag::Variable& motion, const Tensor& motion_mask,
                                             const ag::Variable& text, const Tensor& text_mask,
                                             const ag::Variable& alpha, const FrameTokenOptions& opt) {
  if (motion.defined() && text.defined() && motion.dim() >= 1 && text.dim() >= 1 && motion.size(0) != text.size(0))
    throw Error(std::string(kOp) + ": the loss needs matched pairs (Bm == Bt), got motion " +
                shape_str(motion.shape()) + " and text " + shape_str(text.shape()));
  ag::Variable r = frame_token_similarity(motion, motion_mask, text, text_mask, opt);
  if (!alpha.defined() || alpha.dtype() != r.dtype())
    throw Error(std::string(kOp) + ": alpha must be defined with the features' dtype " + dtype_name(r.dtype()));
  ag::Variable logits = ag::mul(r, logit_scale_gamma(alpha, kOp));
  return symmetric_contrastive(logits, opt.text_ids);
}

}  // namespace t2m::nn
