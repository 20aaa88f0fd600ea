// loss_token_pool.h — the token pooling of Eq 8 as one fused op with its own backward: a masked log-mean-exp
// over the last dim. Used by nn/loss_frame_token.h, where x is the (Bm·Tm, Bt, K) score tensor S/λtok; fusing
// keeps one copy of it alive (the op saves x itself) instead of the masked copy and temporaries of
// masked_fill + logsumexp.
//
// masked_log_mean_exp(x, valid):
//   x (N, J, K) float32/float64 (any strides; made contiguous once), valid (J, K) any dtype, nonzero = valid.
//   out (N, J):  out[n, j] = log( (1/K_j) Σ_{k: valid[j, k]} exp(x[n, j, k]) ),   K_j = #valid k of row j
//   computed as max + log Σ exp(x − max) over the valid k (finite for any finite x; sums in double).
//   Backward (a masked softmax; padded entries get exactly 0 whatever x holds there), saving x and the per-row
//   log Σ exp in float64 (N·J doubles, so float32 rounding of a large out does not skew the gradient):
//   dx[n, j, k] = g[n, j] · [valid[j, k]] · exp(x[n, j, k] − out[n, j] − log K_j)
//   Deterministic: each (n, j) row is reduced by one thread in index order.
// Errors (t2m::Error, "masked_log_mean_exp: ..."): x not 3-D or not float, valid not (J, K) (names both shapes),
//   a row j with no valid entry.
#pragma once
#include "autograd/variable.h"

namespace t2m::nn {

ag::Variable masked_log_mean_exp(const ag::Variable& x, const Tensor& valid);

}  // namespace t2m::nn
