// layer_norm_tanh.h — tanh(LayerNorm(x)) as one differentiable op: the "Linear -> LayerNorm -> Tanh" stem of
// every FB network (fb_networks.h). One pass forward (the LayerNorm kernel of tensor/fused/layer_norm.h, then a
// vectorisable tanh in place), one pass backward (the LayerNorm backward, each row's g (1 - y^2) formed on the
// fly). Saves x, y and the row statistics, not the normalised pre-activation.
//
// layer_norm_tanh(x, weight, bias, eps): x [..., C]; weight, bias [C] or undefined -> y [..., C].
// float32 uses tanh(u) = sign(u) (1 - 2 / (e^{2|u|} + 1)) with a polynomial exp (absolute error < 3e-7 against
// std::tanh, tested); float64 uses std::tanh (gradchecks).
// fast_tanh(u): that float approximation alone (exposed for its test).
// Errors (t2m::Error "layer_norm_tanh: ..."): non-float or mixed dtypes, x 0-d or with an empty last dim,
// weight/bias not [C].
#pragma once
#include "autograd/variable.h"

namespace t2m::bfm {

ag::Variable layer_norm_tanh(const ag::Variable& x, const ag::Variable& weight, const ag::Variable& bias,
                             double eps = 1e-5);
float fast_tanh(float u);

}  // namespace t2m::bfm
