// diffusion_generate.cpp — batching captions through the frozen text encoder and the guided sampler.
#include "models/casim/diffusion_generate.h"

#include <algorithm>

#include "autograd/no_grad.h"
#include "models/text/text_motion_model.h"

namespace t2m::casim {

DiffusionText encode_diffusion_text(const text::RetrievalBundle& tb, const std::vector<std::string>& captions) {
  if (captions.empty()) throw Error("casim generate: no captions");
  const auto* tm = dynamic_cast<const text::TextMotionModel*>(tb.model.get());
  if (!tm) throw Error("casim generate: the text bundle is not a text_encoder checkpoint");
  const auto& enc = tm->text();
  const text::EncodedBatch eb = text::encode_captions(tb.tokenizer, captions, enc.config().max_len);
  ag::NoGradGuard ng;
  const text::TextFeatures f = enc.forward(eb.ids, eb.mask);
  DiffusionText d;
  d.tokens = f.tokens.data().contiguous();
  d.tok_mask = eb.mask.to(DType::f32).contiguous();
  d.pooled = f.pooled.data().contiguous();
  return d;
}

std::vector<std::vector<float>> generate_motion_features(const DiffusionBundle& b, const text::RetrievalBundle& tb,
                                                         const std::vector<std::string>& captions,
                                                         const std::vector<int64_t>& frames,
                                                         const SamplerOptions& opt, uint64_t seed, int64_t batch) {
  if (captions.empty()) throw Error("casim generate: no captions");
  if (frames.size() != captions.size()) throw Error("casim generate: captions and frame counts differ in number");
  if (batch < 1) throw Error("casim generate: batch must be >= 1");
  for (int64_t f : frames)
    if (f < 1) throw Error("casim generate: a motion needs >= 1 frame (got " + std::to_string(f) + ")");
  const DiffusionSchedule sch = cosine_schedule(b.model->config().diffusion_steps);
  const int64_t F = b.model->config().feature_dim, N = (int64_t)captions.size();
  std::vector<std::vector<float>> out;
  for (int64_t s = 0, k = 0; s < N; s += batch, ++k) {
    const int64_t n = std::min(batch, N - s);
    const std::vector<std::string> caps(captions.begin() + s, captions.begin() + s + n);
    const DiffusionText text = encode_diffusion_text(tb, caps);
    int64_t T = 0;
    for (int64_t i = 0; i < n; ++i) T = std::max(T, frames[(size_t)(s + i)]);
    Tensor mask = Tensor::zeros({n, T});
    for (int64_t i = 0; i < n; ++i) std::fill_n(mask.data<float>() + i * T, frames[(size_t)(s + i)], 1.f);
    Generator g(seed + 7919 * (uint64_t)k);
    const Tensor x = sample_motions(*b.model, sch, text, mask, T, opt, g).to(DType::f32).contiguous();
    for (int64_t i = 0; i < n; ++i) {
      const int64_t len = frames[(size_t)(s + i)];
      std::vector<float> rows(x.data<float>() + i * T * F, x.data<float>() + (i * T + len) * F);
      data::denormalize_features(rows, b.stats);
      out.push_back(std::move(rows));
    }
  }
  return out;
}

}  // namespace t2m::casim
