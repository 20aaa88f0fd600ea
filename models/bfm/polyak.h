// polyak.h — soft target-network update theta_t <- (1 - tau) theta_t + tau theta (Polyak averaging), in place,
// the anchor's torch._foreach_mul_(t, 1 - tau); torch._foreach_add_(t, p, alpha=tau) (same two roundings).
// target and source: parameter lists of one architecture (same count, shapes, dtype), float32 or float64.
// Elementwise, so bitwise independent of the thread count. Errors (t2m::Error "polyak_update: ..."): tau outside
// [0, 1], list sizes or a shape/dtype differing (names the parameter).
#pragma once
#include <vector>

#include "autograd/variable.h"

namespace t2m::bfm {

void polyak_update(const std::vector<ag::Variable>& target, const std::vector<ag::Variable>& source, double tau);

}  // namespace t2m::bfm
