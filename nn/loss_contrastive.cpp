// loss_contrastive.cpp — Eq 11–12 on a logits matrix (row/column logsumexp minus the diagonal), false-negative
// exclusion by caption id, CLIP-clamped logit scale, L2 normalisation, InfoNCE on pooled embeddings.
#include "nn/loss_contrastive.h"

#include <algorithm>
#include <limits>
#include <string>

#include "autograd/ops_elementwise.h"
#include "autograd/ops_index.h"
#include "autograd/ops_linalg.h"
#include "autograd/ops_reduce.h"
#include "autograd/ops_unary.h"

namespace t2m::nn {
namespace {

bool is_float(DType d) { return d == DType::f32 || d == DType::f64; }

void check_alpha(const ag::Variable& alpha, const char* op) {
  if (!alpha.defined()) throw Error(std::string(op) + ": logit scale alpha is undefined");
  if (alpha.numel() != 1)
    throw Error(std::string(op) + ": logit scale alpha must have one element, got " + shape_str(alpha.shape()));
  if (!is_float(alpha.dtype()))
    throw Error(std::string(op) + ": logit scale alpha must be float32/float64, got " + dtype_name(alpha.dtype()));
}

// (B, B) 0/1 mask of the false negatives: i != j with the same caption id.
Tensor false_negative_mask(const Tensor& text_ids, int64_t B, DType dtype, const char* op) {
  if (text_ids.dtype() != DType::i64 || text_ids.shape() != Shape{B})
    throw Error(std::string(op) + ": text_ids must be int64 of shape " + shape_str({B}) + ", got " +
                dtype_name(text_ids.dtype()) + " " + shape_str(text_ids.shape()));
  const std::vector<int64_t> ids = text_ids.to_vector<int64_t>();
  Tensor m = Tensor::zeros({B, B}, DType::f64);
  double* pm = m.data<double>();
  for (int64_t i = 0; i < B; ++i)
    for (int64_t j = 0; j < B; ++j) pm[i * B + j] = (i != j && ids[i] == ids[j]) ? 1.0 : 0.0;
  return m.to(dtype);
}

}  // namespace

ag::Variable logit_scale_gamma(const ag::Variable& alpha, const char* op) {
  check_alpha(alpha, op);
  return ag::exp(ag::clamp(alpha, 0.0, kMaxLogitScale));  // γ = exp(α), Eq 11, clamped like CLIP
}

void clamp_logit_scale_(const ag::Variable& alpha) {
  check_alpha(alpha, "clamp_logit_scale_");
  if (!alpha.is_leaf()) throw Error("clamp_logit_scale_: alpha must be a leaf (the parameter itself)");
  Tensor& d = alpha.data();
  d.fill_(std::clamp(d.item(), 0.0, kMaxLogitScale));
}

// logits (B, B) -> Eq 11 both directions and Eq 12
ContrastiveLoss symmetric_contrastive(const ag::Variable& logits, const Tensor& text_ids) {
  const char* op = "symmetric_contrastive";
  if (!logits.defined()) throw Error(std::string(op) + ": logits are undefined");
  if (logits.dim() != 2 || logits.size(0) != logits.size(1) || logits.size(0) < 1)
    throw Error(std::string(op) + ": logits must be a square (B, B) matrix with B >= 1, got " +
                shape_str(logits.shape()));
  if (!is_float(logits.dtype()))
    throw Error(std::string(op) + ": logits must be float32/float64, got " + dtype_name(logits.dtype()));
  const int64_t B = logits.size(0);
  Tensor diag_index = Tensor::arange(B, DType::i64).reshape({B, 1});
  ag::Variable diag = ag::gather(logits, 1, diag_index).reshape({B});  // L[i][i]
  ag::Variable L = logits;
  if (text_ids.defined())
    L = ag::masked_fill(logits, false_negative_mask(text_ids, B, logits.dtype(), op),
                        -std::numeric_limits<double>::infinity());
  ContrastiveLoss r;
  r.logits = logits;
  r.motion_to_text = ag::mean(ag::sub(ag::logsumexp(L, 1), diag));  // rows: motion i against all texts
  r.text_to_motion = ag::mean(ag::sub(ag::logsumexp(L, 0), diag));  // columns: text j against all motions
  r.loss = ag::mul(ag::add(r.motion_to_text, r.text_to_motion), 0.5);
  return r;
}

// x (..., D) -> x / max(||x||, eps) along the last dim
ag::Variable l2_normalize(const ag::Variable& x, double eps) {
  ag::Variable sumsq = ag::sum(ag::square(x), {-1}, /*keepdim=*/true);
  return ag::mul(x, ag::rsqrt(ag::clamp(sumsq, eps * eps, std::numeric_limits<double>::infinity())));
}

// motion (B, D), text (B, D) -> symmetric InfoNCE over γ · cos
ContrastiveLoss info_nce(const ag::Variable& motion, const ag::Variable& text, const ag::Variable& alpha,
                         const Tensor& text_ids, bool normalize) {
  const char* op = "info_nce";
  if (!motion.defined() || !text.defined()) throw Error(std::string(op) + ": motion or text is undefined");
  if (motion.dim() != 2 || text.dim() != 2 || motion.shape() != text.shape())
    throw Error(std::string(op) + ": motion and text must both be (B, D), got " + shape_str(motion.shape()) +
                " and " + shape_str(text.shape()));
  if (motion.dtype() != text.dtype() || !is_float(motion.dtype()))
    throw Error(std::string(op) + ": motion and text must share a float dtype, got " +
                dtype_name(motion.dtype()) + " and " + dtype_name(text.dtype()));
  check_alpha(alpha, op);
  if (alpha.dtype() != motion.dtype())
    throw Error(std::string(op) + ": alpha is " + dtype_name(alpha.dtype()) + " but the embeddings are " +
                dtype_name(motion.dtype()));
  ag::Variable m = normalize ? l2_normalize(motion) : motion;
  ag::Variable t = normalize ? l2_normalize(text) : text;
  ag::Variable logits = ag::mul(ag::matmul_t(m, false, t, true), logit_scale_gamma(alpha, op));  // (B, B)
  return symmetric_contrastive(logits, text_ids);
}

}  // namespace t2m::nn
