// flow_sampler.cpp — Euler integration of Eq 16 and the guided generator field (cond + null in one batch).
#include "models/text2bfm/flow_sampler.h"

#include <cmath>
#include <string>

#include "autograd/no_grad.h"
#include "autograd/ops_join.h"
#include "tensor/ops.h"

namespace t2m::text2bfm {

// Text2BFM Eq 16: m_{k+1} = m_k + h v(m_k, k h), h = 1/steps
Tensor euler_integrate(const VelocityField& v, const Tensor& m0, int64_t steps) {
  if (steps < 1) throw Error("flow_sampler: steps must be >= 1, got " + std::to_string(steps));
  if (m0.dim() < 1) throw Error("flow_sampler: m0 must have a batch dim, got " + shape_str(m0.shape()));
  const double h = 1.0 / (double)steps;
  Tensor m = m0.clone();
  for (int64_t k = 0; k < steps; ++k) {
    const Tensor r = Tensor::full({m.size(0)}, (double)k * h, m.dtype());
    const Tensor vk = v(m, r);
    if (!vk.defined() || vk.shape() != m.shape() || vk.dtype() != m.dtype())
      throw Error("flow_sampler: the velocity field must return " + shape_str(m.shape()) + " " +
                  dtype_name(m.dtype()) + ", got " + (vk.defined() ? shape_str(vk.shape()) + " " +
                  dtype_name(vk.dtype()) : std::string("undefined")));
    m = add(m, mul(vk, h));
  }
  return m;
}

// classifier-free guidance: v_u + w (v_c - v_u)
Tensor guided_velocity(const Tensor& v_cond, const Tensor& v_uncond, double w) {
  if (v_cond.shape() != v_uncond.shape())
    throw Error("flow_sampler: guided_velocity needs equal shapes, got " + shape_str(v_cond.shape()) + " and " +
                shape_str(v_uncond.shape()));
  if (w == 1.0) return v_cond.clone();
  if (w == 0.0) return v_uncond.clone();
  return add(v_uncond, mul(sub(v_cond, v_uncond), w));
}

VelocityField guided_field(const FlowGenerator& gen, const Tensor& tokens, const Tensor& tok_mask, double w) {
  const FlowGeneratorConfig& cf = gen.config();
  if (!std::isfinite(w)) throw Error("flow_sampler: guidance must be finite");
  if (tokens.dim() != 3 || tokens.size(2) != cf.adapter.tok_dim)
    throw Error("flow_sampler: tokens must be (B, L, " + std::to_string(cf.adapter.tok_dim) + "), got " +
                shape_str(tokens.shape()));
  ag::NoGradGuard no_grad;
  const DType dt = gen.null_ctx().dtype();
  const int64_t B = tokens.size(0);
  FlowContext cond, both;
  if (w != 0.0) cond = gen.encode_text(ag::Variable(tokens.to(dt)), tok_mask);
  if (w != 0.0 && w != 1.0) {  // [cond ; null] as one batch of 2B: the null rows see S copies of null_ctx
    const Tensor drop = concat({Tensor::zeros({B}), Tensor::ones({B})}, 0);
    FlowContext twice{ag::concat({cond.ctx, cond.ctx}, 0),
                      tok_mask.defined() ? concat({tok_mask.to(DType::f32), tok_mask.to(DType::f32)}, 0) : Tensor()};
    both = gen.drop_condition(twice, drop);
  }
  const FlowContext null = gen.null_context(B);
  return [&gen, cond, both, null, w, B](const Tensor& m, const Tensor& r) -> Tensor {
    ag::NoGradGuard ng;
    if (w == 1.0) return gen.velocity(ag::Variable(m), r, cond).data();
    if (w == 0.0) return gen.velocity(ag::Variable(m), r, null).data();
    const Tensor v2 = gen.velocity(ag::Variable(concat({m, m}, 0)), concat({r, r}, 0), both).data();
    return guided_velocity(v2.narrow(0, 0, B), v2.narrow(0, B, B), w);
  };
}

Tensor sample_programs(const FlowGenerator& gen, const Tensor& tokens, const Tensor& tok_mask, int64_t Tm,
                       Generator& rng, const FlowSamplerOptions& opt) {
  if (Tm < 1) throw Error("flow_sampler: Tm must be >= 1, got " + std::to_string(Tm));
  const VelocityField field = guided_field(gen, tokens, tok_mask, opt.guidance);
  ag::NoGradGuard no_grad;
  const Tensor m0 = rand_normal({tokens.size(0), Tm, gen.config().latent}, rng, 0.0, 1.0, gen.null_ctx().dtype());
  return euler_integrate(field, m0, opt.steps);
}

}  // namespace t2m::text2bfm
