// latent_inference.h — Text2BFM Eq 2: the tracking latents of a clip from its backward embeddings.
//
// tracking_latents(b, L): b [n, d] = B(s_1), ..., B(s_n) (the embeddings of states s_1..s_{T-1}, i.e. every
//   state but the first, n = T - 1). Returns z [n, d] with, for 0-based t = 0..n-1,
//     z_t = Proj( 1/H_t sum_{k=0}^{H_t - 1} b_{t+k} ),  H_t = min(L, n - t),  Proj(u) = sqrt(d) u / |u|
//   which is Eq 2's z_t = Proj(1/H_t sum_k B(s_{t+1+k})), H_t = min(L, T - t) in the paper's 1-based indexing.
//   Window sums use a running sum in double (O(n d)). float32 or float64; result in b's dtype.
// Errors (t2m::Error "tracking_latents: ..."): b not 2-D, n < 1, d < 1, L < 1, non-float dtype.
#pragma once
#include "tensor/tensor.h"

namespace t2m::bfm {

Tensor tracking_latents(const Tensor& b, int L);

}  // namespace t2m::bfm
