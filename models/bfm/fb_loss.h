// fb_loss.h — the forward-backward temporal-difference loss, the orthonormality regularizer on B and the
// pessimistic ensemble (Meta Motivo's FB agent; the anchor's fb_update in ../shared/anchor/torch_ref.py).
//
// Notation: E ensemble members, B batch rows, d latent dim. M_e = F_e(s, a, z) B(s')^T [E, B, B] predicts the
// successor measure of (s_i, a_i, z_i) at the goal s'_j; the target tM [B, B] comes from the target networks at
// (s', a' ~ pi(s', z)).
//
// offdiag_diag_loss(X, target, gamma): one fused op (forward and backward), X [E, B, B], target [B, B] or
//   undefined (= 0), gamma [B] or undefined (= 0: no bootstrap):
//     diff_eij = X_eij - gamma_i target_ij
//     L = sum_e [ 0.5 sum_{i != j} diff_eij^2 / (B (B - 1)) - sum_i diff_eii / B ]
//   (torch: 0.5 (diff * off_diag).pow(2).sum() / off_diag.sum() - diagonal(diff).mean() * E).
//   dL/dX_eij = diff_eij / (B (B - 1)) for i != j, -1/B on the diagonal. parts (optional) receives the two terms.
//   Reductions: per-row partial sums in double, added in row order: the same bits for any thread count.
// fb_td_loss(F, Bv, target_M, gamma, parts): the FB TD loss = offdiag_diag_loss(F Bv^T, target_M, gamma);
//   F [E, B, d] (stacked members), Bv [B, d] = B(s'), gamma = discount * not_done [B].
// ortho_loss(Bv): the orthonormality regularizer = offdiag_diag_loss(Bv Bv^T, -, -) on C = Bv Bv^T [B, B]:
//   0.5 mean_{i != j} C_ij^2 - mean_i C_ii   (an unbiased estimate of |Cov(B) - I|^2 up to a constant).
// pessimistic(x, p): over dim 0 (members): mean_e x_e - p * (sum_{e < e'} |x_e - x_e'| / (E (E - 1) / 2)) / 2;
//   E = 1 gives x_0. x [E, ...] -> [...]. (E = 2, p = 0.5: the anchor's mean - 0.5 |x_0 - x_1| / 2.)
// pessimistic_target_M(Ft, Bt, p): no graph, pessimistic(Ft Bt^T, p): Ft [E, B, d], Bt [B, d] -> [B, B].
// float32 and float64. Errors (t2m::Error naming the function and shapes): X not 3-D with square trailing dims,
// B < 2, target/gamma of the wrong shape or dtype, F/Bv shape mismatch, E < 1.
#pragma once
#include "autograd/variable.h"

namespace t2m::bfm {

struct FbLossParts {
  double offdiag = 0;  // sum over members of the off-diagonal term
  double diag = 0;     // sum over members of -mean_i diff_ii
};

ag::Variable offdiag_diag_loss(const ag::Variable& X, const Tensor& target, const Tensor& gamma,
                               FbLossParts* parts = nullptr);
ag::Variable fb_td_loss(const ag::Variable& F, const ag::Variable& Bv, const Tensor& target_M, const Tensor& gamma,
                        FbLossParts* parts = nullptr);
ag::Variable ortho_loss(const ag::Variable& Bv, FbLossParts* parts = nullptr);
ag::Variable pessimistic(const ag::Variable& x, double p);
Tensor pessimistic_target_M(const Tensor& Ft, const Tensor& Bt, double p);

}  // namespace t2m::bfm
