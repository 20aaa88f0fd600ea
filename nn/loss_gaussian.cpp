// loss_gaussian.cpp — closed-form Gaussian KLs composed from autograd ops (exp, square, sums); see the header.
#include "nn/loss_gaussian.h"

#include <string>

#include "autograd/no_grad.h"
#include "autograd/ops_elementwise.h"
#include "autograd/ops_reduce.h"
#include "autograd/ops_unary.h"
#include "nn/loss_reduce.h"

namespace t2m::nn {
namespace {

void check_same(const ag::Variable& a, const ag::Variable& b, const char* op, const char* na, const char* nb) {
  if (!a.defined() || !b.defined()) throw Error(std::string(op) + ": " + na + " or " + nb + " is undefined");
  if (a.shape() != b.shape())
    throw Error(std::string(op) + ": " + na + " " + shape_str(a.shape()) + " and " + nb + " " +
                shape_str(b.shape()) + " must have the same shape");
  if (a.dtype() != b.dtype())
    throw Error(std::string(op) + ": " + na + " is " + dtype_name(a.dtype()) + " but " + nb + " is " +
                dtype_name(b.dtype()));
}

void check_scale(const ag::Variable& s, const ag::Variable& mu, const char* op, const char* name) {
  if (!s.defined()) throw Error(std::string(op) + ": " + name + " is undefined");
  if (!broadcasts_to(s.shape(), mu.shape()))
    throw Error(std::string(op) + ": " + name + " " + shape_str(s.shape()) + " does not broadcast to mu " +
                shape_str(mu.shape()));
  if (s.dtype() != mu.dtype())
    throw Error(std::string(op) + ": " + name + " is " + dtype_name(s.dtype()) + " but mu is " +
                dtype_name(mu.dtype()));
}

}  // namespace

// Eq 6: mu, logvar (B, ...) -> scalar; k = 0.5 (mu² + e^logvar - 1 - logvar) per element
ag::Variable kl_standard_normal(const ag::Variable& mu, const ag::Variable& logvar, KlReduction reduction,
                                const Tensor& weights) {
  const char* op = "kl_standard_normal";
  check_same(mu, logvar, op, "mu", "logvar");
  ag::Variable k = ag::mul(ag::sub(ag::add(ag::square(mu), ag::exp(logvar)), ag::add(logvar, 1.0)), 0.5);
  if (reduction == KlReduction::mean_elements) return weighted_mean(k, weights, op);
  ag::Variable total = weighted_sum(k, weights, op);
  if (reduction == KlReduction::sum) return total;
  if (mu.dim() == 0) throw Error(std::string(op) + ": batch_mean needs a batch dim, got a 0-d mu");
  return ag::div(total, (double)mu.size(0));
}

// Eq 5 / Eq 21: (mu1, s1) || (mu2, s2), all (..., A) -> (...)
ag::Variable kl_diag_gaussians(const ag::Variable& mu1, const ag::Variable& scale1, const ag::Variable& mu2,
                               const ag::Variable& scale2, GaussianScale param) {
  const char* op = "kl_diag_gaussians";
  check_same(mu1, mu2, op, "mu1", "mu2");
  if (mu1.dim() == 0) throw Error(std::string(op) + ": mu must be at least 1-D (..., A), got a 0-d tensor");
  check_scale(scale1, mu1, op, "scale1");
  check_scale(scale2, mu1, op, "scale2");
  // with l = log σ:  (l2 - l1) + 0.5 (e^{2(l1 - l2)} + (mu1 - mu2)² e^{-2 l2}) - 0.5
  // with v = log σ²: 0.5 (v2 - v1) + 0.5 (e^{v1 - v2} + (mu1 - mu2)² e^{-v2}) - 0.5
  const double c = param == GaussianScale::log_std ? 2.0 : 1.0;  // log σ² = c * scale
  ag::Variable dlog = ag::sub(scale2, scale1);                   // broadcast of the two scales
  ag::Variable ratio = ag::exp(ag::mul(dlog, -c));               // σ1² / σ2²
  ag::Variable inv_var2 = ag::exp(ag::mul(scale2, -c));          // 1 / σ2²
  ag::Variable d2 = ag::square(ag::sub(mu1, mu2));
  ag::Variable per = ag::add(ag::mul(dlog, c * 0.5), ag::mul(ag::add(ratio, ag::mul(d2, inv_var2)), 0.5));
  ag::Variable summed = ag::sum(ag::sub(per, 0.5), {-1});  // per broadcasts to mu's shape through d2
  return summed;
}

double action_kl(const Tensor& mu_hat, const Tensor& scale_hat, const Tensor& mu, const Tensor& scale,
                 GaussianScale param, const Tensor& frame_weights) {
  ag::NoGradGuard guard;
  ag::Variable kl = kl_diag_gaussians(ag::Variable(mu_hat), ag::Variable(scale_hat), ag::Variable(mu),
                                      ag::Variable(scale), param);
  return weighted_mean(kl, frame_weights, "action_kl").item();
}

}  // namespace t2m::nn
