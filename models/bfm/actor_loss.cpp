// actor_loss.cpp — actor objective pieces composed from autograd ops (they are cheap next to the networks).
#include "models/bfm/actor_loss.h"

#include <cmath>
#include <string>

#include "autograd/ops_elementwise.h"
#include "autograd/ops_reduce.h"
#include "autograd/ops_unary.h"
#include "models/bfm/fb_loss.h"
#include "tensor/ops.h"

namespace t2m::bfm {

Tensor policy_noise(const Shape& shape, double std, double clip, Generator& gen, DType dtype) {
  if (!(std >= 0)) throw Error("policy_noise: std must be >= 0, got " + std::to_string(std));
  if (std == 0) return Tensor::zeros(shape, dtype);
  Tensor n = rand_normal(shape, gen, 0.0, std, dtype);
  return clip > 0 ? t2m::clamp(n, -clip, clip) : n;
}

// mu [N, A] + noise [N, A] -> clamp to [-1, 1]
ag::Variable noisy_action(const ag::Variable& mu, const Tensor& noise) {
  if (mu.shape() != noise.shape())
    throw Error("noisy_action: mu " + shape_str(mu.shape()) + " and noise " + shape_str(noise.shape()) + " differ");
  return ag::clamp(mu + ag::Variable(noise), -1.0, 1.0);
}

// F [E, N, d], z [N, d] -> [E, N]
ag::Variable q_values(const ag::Variable& F, const ag::Variable& z) {
  if (F.dim() != 3 || z.dim() != 2 || F.size(1) != z.size(0) || F.size(2) != z.size(1))
    throw Error("q_values: F must be [E, N, d] and z [N, d], got " + shape_str(F.shape()) + " and " +
                shape_str(z.shape()));
  return ag::sum(F * z.unsqueeze(0), {-1});
}

// Q [E, N] -> scalar
ag::Variable actor_q_loss(const ag::Variable& Q, double pessimism, bool normalize, double* q_mean) {
  if (Q.dim() != 2) throw Error("actor_q_loss: Q must be [E, N], got " + shape_str(Q.shape()));
  const ag::Variable q = pessimistic(Q, pessimism);
  const ag::Variable m = ag::mean(q);
  if (q_mean) *q_mean = m.item();
  double scale = 1;
  if (normalize) {
    const double a = t2m::mean(t2m::abs(q.data())).item();
    if (a > 0) scale = a;
  }
  return m * (-1.0 / scale);
}

// mu [N, A], a_data [N, A] -> scalar
ag::Variable bc_loss(const ag::Variable& mu, const Tensor& a_data) {
  if (mu.shape() != a_data.shape())
    throw Error("bc_loss: mu " + shape_str(mu.shape()) + " and data actions " + shape_str(a_data.shape()) +
                " differ");
  return ag::mean(ag::square(mu - ag::Variable(a_data)));
}

}  // namespace t2m::bfm
