// loss_flow.h — conditional flow matching on the linear path (Text2BFM Eq 14–15; rectified flow).
//
// Convention (the paper's and the anchor's): x0 = ε ~ N(0, I) is noise, x1 = m is data, t ∈ [0, 1] per sample.
//   flow_interpolate(x0, x1, t) -> { x_t, velocity }:
//     Eq 14: x_t = (1 − t) x0 + t x1      Eq 15 target: velocity = x1 − x0 (constant along the path)
//     x0, x1: one shape (B, ...), one float dtype; t: (B,) (or one element, shared), broadcast over the other
//     dims. Gradients to x0, x1 and t (d x_t / d t = x1 − x0).
//   flow_matching_loss(v_pred, x0, x1, opt) = mse_loss(v_pred, x1 − x0, opt)   (Eq 15)
//     Default reduction: mean over all elements (the anchor's F.mse_loss); opt.sum_last_dim = true gives the
//     squared L2 norm over the feature dim averaged over frames and batch, i.e. Eq 15's expectation of
//     ||v − (m − ε)||² per frame; opt.weights masks padded latent frames (nn/loss_regression.h).
//   sample_flow_time(B, gen, opt, dtype) -> (B,) times drawn from `gen` (deterministic in its seed/offset):
//     uniform       t ~ U[0, 1)  (Eq 14, the default);
//     logit_normal  t = sigmoid(mean + std · n), n ~ N(0, 1) (Esser et al. 2024 "SD3"; an option only).
//   sample_flow_pair(x1, gen, opt) -> { x0 = ε ~ N(0, I) of x1's shape, t, x_t, velocity }: one training draw.
// Errors ("flow_interpolate: ..." etc.): x0/x1 shapes or dtypes differ, 0-d data, t not (B,) or one element,
// B < 0, std < 0 for logit_normal.
#pragma once
#include <cstdint>

#include "autograd/variable.h"
#include "nn/loss_regression.h"
#include "tensor/rng.h"

namespace t2m::nn {

struct FlowPoint {
  ag::Variable x_t;       // Eq 14
  ag::Variable velocity;  // x1 − x0, the target of Eq 15
};

FlowPoint flow_interpolate(const ag::Variable& x0, const ag::Variable& x1, const ag::Variable& t);

ag::Variable flow_matching_loss(const ag::Variable& v_pred, const ag::Variable& x0, const ag::Variable& x1,
                                const MseOptions& opt = {});

enum class FlowTimeSampling { uniform, logit_normal };
struct FlowTimeOptions {
  FlowTimeSampling kind = FlowTimeSampling::uniform;
  double mean = 0.0;  // logit_normal only
  double std = 1.0;   // logit_normal only
};

Tensor sample_flow_time(int64_t batch, Generator& gen, const FlowTimeOptions& opt = {}, DType dtype = DType::f32);

struct FlowSample {
  Tensor x0;  // noise ε
  Tensor t;   // (B,)
  Tensor x_t;
  Tensor velocity;
};
// x1: the data batch (B, ...). Draws t first, then ε, from gen.
FlowSample sample_flow_pair(const Tensor& x1, Generator& gen, const FlowTimeOptions& opt = {});

}  // namespace t2m::nn
