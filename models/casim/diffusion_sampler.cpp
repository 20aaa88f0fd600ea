// diffusion_sampler.cpp — the reverse-process loop and the guided two-pass x0-prediction.
#include "models/casim/diffusion_sampler.h"

#include <cmath>
#include <string>

#include "autograd/no_grad.h"
#include "tensor/ops.h"

namespace t2m::casim {

Tensor diffusion_sample(const DiffusionSchedule& sch, const X0Predictor& x0_fn, const Tensor& x_T,
                        const SamplerOptions& opt, Generator& gen) {
  const std::vector<int64_t> ts = sampling_timesteps(sch.steps, opt.steps);
  Tensor x = x_T.contiguous();
  for (size_t k = 0; k < ts.size(); ++k) {
    const Tensor x0 = x0_fn(x, ts[k]);
    if (!x0.defined() || x0.shape() != x.shape() || x0.dtype() != x.dtype())
      throw Error("diffusion sampler: the x0 predictor returned a tensor of another shape or dtype at step " +
                  std::to_string(ts[k]));
    x = reverse_step(sch, x, x0, ts[k], k + 1 < ts.size() ? ts[k + 1] : -1, opt.eta, gen);
  }
  return x;
}

// Ho & Salimans 2022 Eq 6: u + w (c - u).
Tensor guided_x0(const Tensor& cond, const Tensor& uncond, double w) {
  if (!std::isfinite(w)) throw Error("diffusion sampler: guidance weight must be finite");
  if (w == 1.0) return cond;
  return add(uncond, mul(sub(cond, uncond), w));
}

Tensor sample_motions(const CasimDenoiser& model, const DiffusionSchedule& sch, const DiffusionText& text,
                      const Tensor& frame_mask, int64_t T, const SamplerOptions& opt, Generator& gen) {
  if (T < 1) throw Error("diffusion sampler: T must be >= 1");
  if (!std::isfinite(opt.guidance)) throw Error("diffusion sampler: guidance weight must be finite");
  const int64_t B = text.tokens.defined() ? text.tokens.size(0) : text.pooled.size(0);
  if (frame_mask.defined() && frame_mask.shape() != Shape{B, T})
    throw Error("diffusion sampler: frame_mask must be (" + std::to_string(B) + ", " + std::to_string(T) + ")");
  ag::NoGradGuard ng;
  const bool two = opt.guidance != 1.0;
  DiffusionText both = text;
  Tensor mask2 = frame_mask, drop;
  if (two) {  // rows [0, B) conditional, [B, 2B) the null condition
    if (text.tokens.defined()) both.tokens = concat({text.tokens, text.tokens}, 0);
    if (text.tok_mask.defined()) both.tok_mask = concat({text.tok_mask, text.tok_mask}, 0);
    if (text.pooled.defined()) both.pooled = concat({text.pooled, text.pooled}, 0);
    if (frame_mask.defined()) mask2 = concat({frame_mask, frame_mask}, 0);
    drop = concat({Tensor::zeros({B}), Tensor::ones({B})}, 0);
  }
  const X0Predictor fn = [&](const Tensor& x, int64_t t) {
    const Tensor xin = two ? concat({x, x}, 0) : x;
    const Tensor tt = Tensor::full({xin.size(0)}, double(t), DType::i64);
    const Tensor out = model.forward(ag::Variable(xin), tt, both, drop, mask2).data();
    if (!two) return out;
    return guided_x0(out.narrow(0, 0, B), out.narrow(0, B, B), opt.guidance).contiguous();
  };
  const Tensor xT = rand_normal({B, T, model.config().feature_dim}, gen);
  return diffusion_sample(sch, fn, xT, opt, gen);
}

}  // namespace t2m::casim
