// sphere_projection.h — Proj_z(u) = r u / max(|u|_2, eps) row-wise (Text2BFM Eq 2's Proj_z with r = sqrt(d);
// torch's F.normalize(u, dim=-1) * r), as one differentiable op with a fused forward/backward.
//
// sphere_project(u, radius, eps): u [..., d] -> [..., d]. Gradient, n = max(|u|, eps), y = u / n:
//   du = r / n (g - (g . y) y)  when |u| > eps;  du = r g / eps otherwise (the clamp is flat in |u|).
// project_rows(u, radius): the same on a plain tensor (no graph), returned fresh.
// float32 and float64; any strides accepted. Errors (t2m::Error "sphere_project: ..."): 0-d input, non-float
// dtype, radius <= 0.
#pragma once
#include "autograd/variable.h"

namespace t2m::bfm {

ag::Variable sphere_project(const ag::Variable& u, double radius, double eps = 1e-12);
Tensor project_rows(const Tensor& u, double radius, double eps = 1e-12);

}  // namespace t2m::bfm
