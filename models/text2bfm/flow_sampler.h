// flow_sampler.h — sampling compact motion programs with the flow generator (Text2BFM Eq 16): integrate
// dm/dr = v(m(r), r, Y) from m(0) = ε ~ N(0, I) at r = 0 to r = 1 with explicit Euler steps, optionally with
// classifier-free guidance (Ho & Salimans 2022).
//
// euler_integrate(v, m0, steps): h = 1 / steps, r_k = k h, m_{k+1} = m_k + h v(m_k, r_k), k = 0 .. steps-1.
//   v: any field (m (B, ...), r (B) of m's dtype) -> tensor of m's shape. Returns m_steps (a fresh tensor).
// guided_velocity(v_cond, v_uncond, w) = v_uncond + w (v_cond - v_uncond): w = 1 gives v_cond exactly,
//   w = 0 the unconditional field.
// sample_programs(gen, tokens, tok_mask, Tm, rng, opt): m(0) ~ N(0, I) (B, Tm, latent) drawn from rng, the text
//   encoded once, then Euler with the guided field; conditional and null-condition passes of a step run as one
//   batch of 2B (w = 1 runs the conditional pass only; w = 0 the unconditional one only). No autograd graph is
//   recorded (NoGradGuard). Returns (B, Tm, latent) in the generator's dtype.
// guided_field(gen, tokens, tok_mask, w): the guided generator field as a VelocityField (what sample_programs
//   integrates; the diffusion sampler (diffusion_sampler.h) uses it for its v prediction): the text context is
//   encoded once here, each call runs the conditional and null passes as one batch of 2B.
// Errors (t2m::Error "flow_sampler: ..."): steps < 1, a field returning the wrong shape or dtype, Tm < 1,
//   non-finite w, tokens not (B, L, tok_dim); generator errors pass through.
#pragma once
#include <cstdint>
#include <functional>

#include "models/text2bfm/generator.h"
#include "tensor/rng.h"
#include "tensor/tensor.h"

namespace t2m::text2bfm {

using VelocityField = std::function<Tensor(const Tensor& m, const Tensor& r)>;

struct FlowSamplerOptions {
  int64_t steps = 16;      // Eq 16 Euler steps (paper: 16)
  double guidance = 1.5;   // classifier-free guidance weight w (paper: 1.5)
};

// Text2BFM Eq 16: explicit Euler on [0, 1].
Tensor euler_integrate(const VelocityField& v, const Tensor& m0, int64_t steps);

// Classifier-free guidance: v_u + w (v_c - v_u).
Tensor guided_velocity(const Tensor& v_cond, const Tensor& v_uncond, double w);

VelocityField guided_field(const FlowGenerator& gen, const Tensor& tokens, const Tensor& tok_mask, double w);

Tensor sample_programs(const FlowGenerator& gen, const Tensor& tokens, const Tensor& tok_mask, int64_t Tm,
                       Generator& rng, const FlowSamplerOptions& opt = {});

}  // namespace t2m::text2bfm
