// z_sampler.h — the latents z the FB agent is trained on: a mix of
//   tracking  Text2BFM Eq 2 on a reference window (L states after a frame drawn uniformly over all frames with a
//             successor, models/bfm/collect.h window_latents),
//   goal      z = B(s) of one state (a next_obs of the batch: row i uses next_obs[(i + n/2) mod n], a state reached
//             from another row, so z is not trivially the row's own successor),
//   random    uniform on the sphere of radius sqrt(d) (normalised Gaussian),
// as in Meta Motivo's mix of expert-encoded, goal and random latents.
//
//   ZMix mix{0.5, 0.2};                                           // 50 % tracking, 20 % goal, 30 % random
//   Tensor z = sample_training_z(256, mix, refs, L, batch.next_obs, encode, gen);   // [256, d]
//
// Each row's kind comes from one uniform draw (u < track: tracking, u < track + goal: goal, else random), all
// draws from gen in a fixed order, so z is a pure function of (gen state, inputs). Errors (t2m::Error
// "sample_training_z: ..."): ratios outside [0, 1] or summing above 1, n < 1, next_obs rows != n (when goal > 0),
// an encoder whose output is not [M, d].
#pragma once
#include "models/bfm/collect.h"

namespace t2m::bfm {

struct ZMix {
  double track = 0.5;
  double goal = 0.2;  // random = 1 - track - goal
};

Tensor sample_training_z(int64_t n, const ZMix& mix, const RefMotions& refs, int L, const Tensor& next_obs,
                         const EncodeFn& encode, int z_dim, Generator& gen);

}  // namespace t2m::bfm
