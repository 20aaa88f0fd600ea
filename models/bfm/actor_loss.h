// actor_loss.h — the FB actor's objective: maximise the pessimistic F(s, a, z)^T z of its own (noisy) action,
// plus a behaviour-cloning term toward data actions (TD3+BC style, the regularizer toward data behaviour of
// ARCHITECTURE.md section 5; Meta Motivo uses a discriminator instead, we chose BC: no extra network, stable
// offline from the PD-tracker buffer, and its weight is scale-free once Q is normalised).
//
// policy_noise(shape, std, clip, gen): clamp(std * N(0, 1), -clip, clip) as a plain tensor [N, A] (Meta Motivo's
//   truncated-normal sample noise; clip <= 0 means no clip). std = 0: zeros (gen untouched).
// noisy_action(mu, noise): clamp(mu + noise, -1, 1) (differentiable in mu; zero gradient where clamped, as in
//   the anchor). mu [N, A] Variable, noise [N, A].
// q_values(F, z): Q_e = sum_k F_ek z_k: F [E, N, d] (stacked members), z [N, d] -> [E, N].
// actor_q_loss(Q, p, normalize, q_mean): Q [E, N] -> -mean_n pess(Q)_n / (normalize ? mean_n |pess(Q)_n| : 1)
//   (the normaliser is a constant: no gradient flows through it; 1 when it is 0). q_mean receives mean pess(Q).
// bc_loss(mu, a_data): mean over all elements of (mu - a_data)^2, mu [N, A] Variable, a_data [N, A].
// Errors (t2m::Error naming the function and both shapes): shape mismatches, std < 0.
#pragma once
#include "autograd/variable.h"
#include "tensor/rng.h"

namespace t2m::bfm {

Tensor policy_noise(const Shape& shape, double std, double clip, Generator& gen, DType dtype = DType::f32);
ag::Variable noisy_action(const ag::Variable& mu, const Tensor& noise);
ag::Variable q_values(const ag::Variable& F, const ag::Variable& z);
ag::Variable actor_q_loss(const ag::Variable& Q, double pessimism, bool normalize, double* q_mean = nullptr);
ag::Variable bc_loss(const ag::Variable& mu, const Tensor& a_data);

}  // namespace t2m::bfm
