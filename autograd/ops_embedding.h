// ops_embedding.h — differentiable embedding lookup (a row gather with a scatter-add backward).
//
// embedding(weight, ids): weight (V, D) float32/float64, ids int64 of any shape S (0-d included)
//   -> out (S..., D), out[i] = weight[ids[i]]. ids are not differentiable.
//   Backward: dweight (V, D) = zeros, then dweight[ids[i]] += g[i] for every i in index order (rows used several
//   times accumulate; deterministic: one fixed order, parallel over the D columns only).
// Errors (t2m::Error, message starts "embedding:"): weight not 2-D or not float, ids not int64, an id outside
//   [0, V) (the message names the id, its position and V).
#pragma once
#include "autograd/variable.h"

namespace t2m::ag {

Variable embedding(const Variable& weight, const Tensor& ids);

}  // namespace t2m::ag
