// program_dataset.cpp — VBB posterior means as generator training data, standardisation, batch sampling.
#include "models/text2bfm/program_dataset.h"

#include <cmath>

#include "autograd/no_grad.h"

namespace t2m::text2bfm {

std::vector<Tensor> encode_programs(const Vbb& vbb, const std::vector<Tensor>& latents) {
  if (latents.empty()) throw Error("program dataset: no clips");
  const int64_t c = vbb.config().compression(), d = vbb.config().in_dim;
  ag::NoGradGuard ng;
  Generator unused(0);
  std::vector<Tensor> out;
  for (size_t i = 0; i < latents.size(); ++i) {
    const Tensor& z = latents[i];
    if (!z.defined() || z.dim() != 2 || z.size(1) != d || z.size(0) < 1)
      throw Error("program dataset: latents of clip " + std::to_string(i) + " must be (Tz >= 1, " +
                  std::to_string(d) + ")");
    const int64_t Tz = z.size(0), Tp = (Tz + c - 1) / c * c;
    Tensor zp = Tensor::empty({1, Tp, d});
    const Tensor zc = z.to(DType::f32).contiguous();
    float* o = zp.data<float>();
    const float* s = zc.data<float>();
    for (int64_t t = 0; t < Tp; ++t)
      for (int64_t k = 0; k < d; ++k) o[t * d + k] = s[std::min(t, Tz - 1) * d + k];
    const VbbPosterior q = vbb.encode(ag::Variable(zp), unused);                     // mu (1, latent, Tm)
    out.push_back(q.mu.data().select(0, 0).transpose(0, 1).contiguous().clone());  // (Tm, latent)
  }
  return out;
}

ProgramDataset make_program_dataset(std::vector<Tensor> programs, std::vector<std::vector<int64_t>> captions,
                                    Tensor tokens, Tensor tok_mask, int64_t window) {
  if (programs.empty()) throw Error("program dataset: no clips");
  if (captions.size() != programs.size()) throw Error("program dataset: captions and programs differ in count");
  if (window < 1) throw Error("program dataset: window must be >= 1");
  if (!tokens.defined() || tokens.dim() != 3 || !tok_mask.defined() ||
      tok_mask.shape() != Shape{tokens.size(0), tokens.size(1)})
    throw Error("program dataset: tokens must be (Ncap, L, D) with a (Ncap, L) mask");
  const int64_t ncap = tokens.size(0), dm = programs[0].size(1);
  for (size_t i = 0; i < captions.size(); ++i) {
    if (captions[i].empty()) throw Error("program dataset: clip " + std::to_string(i) + " has no caption");
    for (int64_t r : captions[i])
      if (r < 0 || r >= ncap) throw Error("program dataset: caption row " + std::to_string(r) + " out of range");
  }
  std::vector<double> sum((size_t)dm, 0.0), sq((size_t)dm, 0.0);
  double n = 0;
  for (auto& p : programs) {
    if (p.dim() != 2 || p.size(1) != dm) throw Error("program dataset: programs of different widths");
    p = p.to(DType::f32).contiguous();
    const float* v = p.data<float>();
    for (int64_t t = 0; t < p.size(0); ++t, n += 1)
      for (int64_t k = 0; k < dm; ++k) sum[(size_t)k] += v[t * dm + k], sq[(size_t)k] += double(v[t * dm + k]) * v[t * dm + k];
  }
  ProgramDataset d;
  d.mean = Tensor::empty({dm});
  d.std = Tensor::empty({dm});
  for (int64_t k = 0; k < dm; ++k) {
    const double mu = sum[(size_t)k] / n;
    d.mean.data<float>()[k] = float(mu);
    d.std.data<float>()[k] = float(std::sqrt(std::max(sq[(size_t)k] / n - mu * mu, 0.0)) + 1e-4);
  }
  for (auto& p : programs) {
    float* v = p.data<float>();
    for (int64_t i = 0; i < p.numel(); ++i)
      v[i] = (v[i] - d.mean.data<float>()[i % dm]) / d.std.data<float>()[i % dm];
  }
  d.programs = std::move(programs);
  d.captions = std::move(captions);
  d.tokens = tokens.to(DType::f32).contiguous();
  d.tok_mask = tok_mask.to(DType::f32).contiguous();
  d.window = window;
  return d;
}

ProgramBatch sample_program_batch(const ProgramDataset& d, int64_t B, Generator& rng) {
  if (B < 1) throw Error("program dataset: batch must be >= 1");
  const int64_t W = d.window, dm = d.mean.numel(), L = d.tokens.size(1), D = d.tokens.size(2);
  const Tensor u = rand_uniform({B, 3}, rng, 0.0, 1.0, DType::f64);  // clip, caption, start
  const double* uu = u.data<double>();
  ProgramBatch b;
  b.m = Tensor::zeros({B, W, dm});
  b.m_mask = Tensor::zeros({B, W});
  b.tokens = Tensor::empty({B, L, D});
  b.tok_mask = Tensor::empty({B, L});
  const int64_t nclips = (int64_t)d.programs.size();
  for (int64_t i = 0; i < B; ++i) {
    const int64_t c = std::min<int64_t>(nclips - 1, int64_t(uu[3 * i] * nclips));
    const auto& caps = d.captions[(size_t)c];
    const int64_t row = caps[(size_t)std::min<int64_t>((int64_t)caps.size() - 1, int64_t(uu[3 * i + 1] * caps.size()))];
    const Tensor& p = d.programs[(size_t)c];
    const int64_t Tm = p.size(0), len = std::min(W, Tm);
    const int64_t start = std::min<int64_t>(Tm - len, int64_t(uu[3 * i + 2] * double(Tm - len + 1)));
    std::copy(p.data<float>() + start * dm, p.data<float>() + (start + len) * dm, b.m.data<float>() + i * W * dm);
    std::fill(b.m_mask.data<float>() + i * W, b.m_mask.data<float>() + i * W + len, 1.f);
    std::copy(d.tokens.data<float>() + row * L * D, d.tokens.data<float>() + (row + 1) * L * D,
              b.tokens.data<float>() + i * L * D);
    std::copy(d.tok_mask.data<float>() + row * L, d.tok_mask.data<float>() + (row + 1) * L,
              b.tok_mask.data<float>() + i * L);
  }
  return b;
}

}  // namespace t2m::text2bfm
