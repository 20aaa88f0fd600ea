// vbb_average_pool.h — the "average pooling" bottleneck of Text2BFM Table 3 written as a VBB (vbb.h) with
// hand-set weights, so that everything that takes a VBB checkpoint (the flow generator's program data set, the
// generation pipeline, `t2m eval text2bfm`) also runs on pooled programs without a second code path.
//
// make_average_pooling_vbb(in_dim = d, compression = c, width = C >= 2d):
//   posterior mean μ_φ(z)_j = mean(z_{j c}, ..., z_{(j+1) c − 1})      (B, Tz, d) -> (B, d, Tz / c), program width d
//   posterior logvar        = −30 everywhere (a point mass for every practical purpose)
//   decoder D_θ(m)_t       = m_{⌊t / c⌋}                              (B, d, Tm) -> (B, Tm c, d), pooling's repeat
// (no Proj: the pipeline projects every decoded latent onto the sphere, vbb_eval's `project` does the same).
// How: depth 0 (no residual blocks, no GroupNorm), every conv reads only its last (current-frame) tap; the ReLUs
// are passed by carrying [x, −x] in the first 2d channels and subtracting them at the output convs; each stride-2
// level's k4 conv (causal, 2 left padding frames) averages its taps 2 and 3, i.e. input frames 2j and 2j + 1.
// Exact up to float rounding (tests/test_vbb_average_pool.cpp). Nothing is learned.
//
// init_vbb_as_average_pooling(vbb): the same weights in a VBB of any depth (latent must equal in_dim, width >=
//   2 in_dim): every residual block's last conv (c2) is zeroed, so each block is the identity and the whole VBB
//   starts exactly at pooling (GroupNorm and dropout sit inside the zeroed branch). Training from there
//   (`t2m train vbb --pool-init`) can only start at pooling's error, not at a random decoder's; channels above
//   2 in_dim of the top-level convs start at zero (the residual blocks' c1 and norms keep their random init).
// Errors (t2m::Error "vbb average pool: ..."): compression not 1, 4, 8 or 16; in_dim < 1; width < 2 in_dim or not a
// multiple of 32 (the GroupNorm groups of VbbConfig, unused at depth 0 but validated); latent != in_dim.
#pragma once
#include <cstdint>
#include <memory>

#include "models/text2bfm/vbb.h"

namespace t2m::text2bfm {

std::unique_ptr<Vbb> make_average_pooling_vbb(int64_t in_dim, int64_t compression, int64_t width = 128);
void init_vbb_as_average_pooling(Vbb& vbb);

}  // namespace t2m::text2bfm
