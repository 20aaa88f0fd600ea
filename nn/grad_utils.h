// grad_utils.h — gradient checks and clipping over a list of named parameters (Module::named_parameters()).
//
// grad_norm: the global L2 norm of all grads, accumulated in double over fixed blocks of 32768 elements per
//   parameter (blocks summed in parallel, then added in parameter-list and block order): deterministic and
//   independent of the thread count. Parameters with an undefined grad count as zero.
// clip_grad_norm: computes grad_norm; when it exceeds max_norm, scales every grad by max_norm / (norm + 1e-6)
//   (torch.nn.utils.clip_grad_norm_). Returns the norm BEFORE clipping. A non-finite norm leaves the grads
//   unchanged (call check_finite_grads to find the culprit).
// check_finite_grads: throws t2m::Error "check_finite_grads: parameter 'NAME' SHAPE has K non-finite gradient
//   values of N (first at flat index I: nan); P parameter(s) affected" for the FIRST parameter (list order) whose
//   grad holds a NaN or Inf; returns normally when all grads are finite.
// Cheap NaN guard per step: a non-finite grad makes the norm non-finite, so
//   double gn = nn::clip_grad_norm(params, 1.0); if (!std::isfinite(gn)) nn::check_finite_grads(params);  // throws
// Errors: max_norm <= 0 or not finite; a grad that is not float32/float64.
#pragma once
#include "nn/optim.h"

namespace t2m::nn {

double grad_norm(const NamedParams& params);
double clip_grad_norm(const NamedParams& params, double max_norm);
void check_finite_grads(const NamedParams& params);

}  // namespace t2m::nn
