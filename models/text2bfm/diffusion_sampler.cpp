// diffusion_sampler.cpp — deterministic DDIM with a v-prediction field, and the guided generator version.
#include "models/text2bfm/diffusion_sampler.h"

#include <string>

#include "autograd/no_grad.h"
#include "tensor/ops.h"

namespace t2m::text2bfm {

// DDIM, eta = 0: x <- alpha_{k+1} (alpha_k x − sigma_k v) + sigma_{k+1} (sigma_k x + alpha_k v)
Tensor ddim_integrate(const VelocityField& v, const Tensor& x1, int64_t steps, nn::NoiseSchedule schedule) {
  if (steps < 1) throw Error("diffusion_sampler: steps must be >= 1, got " + std::to_string(steps));
  if (!x1.defined() || x1.dim() < 1) throw Error("diffusion_sampler: x1 must have a batch dim");
  Tensor x = x1.clone();
  for (int64_t k = 0; k < steps; ++k) {
    const double t = 1.0 - double(k) / double(steps), tn = 1.0 - double(k + 1) / double(steps);
    const double a = nn::schedule_alpha(schedule, t), s = nn::schedule_sigma(schedule, t);
    const double an = nn::schedule_alpha(schedule, std::max(0.0, tn)), sn = nn::schedule_sigma(schedule, std::max(0.0, tn));
    const Tensor vk = v(x, Tensor::full({x.size(0)}, 1.0 - t, x.dtype()));
    if (!vk.defined() || vk.shape() != x.shape() || vk.dtype() != x.dtype())
      throw Error("diffusion_sampler: the field must return " + shape_str(x.shape()) + " " + dtype_name(x.dtype()) +
                  ", got " + (vk.defined() ? shape_str(vk.shape()) + " " + dtype_name(vk.dtype()) : std::string("undefined")));
    const Tensor x0 = sub(mul(x, a), mul(vk, s));   // x̂
    const Tensor eps = add(mul(x, s), mul(vk, a));  // ε̂
    x = add(mul(x0, an), mul(eps, sn));
  }
  return x;
}

Tensor sample_programs_diffusion(const FlowGenerator& gen, const Tensor& tokens, const Tensor& tok_mask, int64_t Tm,
                                 Generator& rng, const DiffusionSamplerOptions& opt) {
  if (Tm < 1) throw Error("diffusion_sampler: Tm must be >= 1, got " + std::to_string(Tm));
  if (opt.steps < 1) throw Error("diffusion_sampler: steps must be >= 1, got " + std::to_string(opt.steps));
  const VelocityField field = guided_field(gen, tokens, tok_mask, opt.guidance);
  ag::NoGradGuard no_grad;
  const Tensor x1 = rand_normal({tokens.size(0), Tm, gen.config().latent}, rng, 0.0, 1.0, gen.null_ctx().dtype());
  return ddim_integrate(field, x1, opt.steps, opt.schedule);
}

}  // namespace t2m::text2bfm
