// ar_sample.cpp — temperature / top-k sampling and the autoregressive loop.
#include "models/casim/ar_sample.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "autograd/no_grad.h"
#include "tensor/ops.h"

namespace t2m::casim {

int64_t sample_from_logits(const float* logits, int64_t V, double temperature, int64_t top_k, bool allow_end,
                           double u) {
  const int64_t Vc = allow_end ? V : V - 1;  // candidates 0 .. Vc-1
  std::vector<int64_t> idx(Vc);
  std::iota(idx.begin(), idx.end(), 0);
  // Sorted by logit (descending), ties by index: deterministic.
  std::stable_sort(idx.begin(), idx.end(), [&](int64_t a, int64_t b) { return logits[a] > logits[b]; });
  if (temperature == 0.0) return idx[0];
  const int64_t k = (top_k > 0 && top_k < Vc) ? top_k : Vc;
  std::vector<double> p(k);
  const double mx = logits[idx[0]];
  double z = 0;
  for (int64_t i = 0; i < k; ++i) z += p[i] = std::exp((logits[idx[i]] - mx) / temperature);
  double acc = 0;
  for (int64_t i = 0; i < k; ++i) {
    acc += p[i] / z;
    if (u < acc) return idx[i];
  }
  return idx[k - 1];
}

std::vector<std::vector<int64_t>> sample_codes(const ArGpt& model, const ArText& text, const ArSampleOptions& opt,
                                               Generator& gen) {
  const auto& cfg = model.config();
  if (!(opt.temperature >= 0) || opt.top_k < 0 || opt.tokens < 0 || opt.tokens > cfg.max_motion)
    throw Error("ar sample: bad options (temperature " + std::to_string(opt.temperature) + ", top_k " +
                std::to_string(opt.top_k) + ", tokens " + std::to_string(opt.tokens) + ", max " +
                std::to_string(cfg.max_motion) + ")");
  ag::NoGradGuard ng;
  const int64_t B = cfg.cond == ArCond::cls ? text.pooled.size(0) : text.tokens.size(0);
  const int64_t V = cfg.codes + 1, end = cfg.end_token();
  const int64_t n_max = opt.tokens > 0 ? opt.tokens : cfg.max_motion;
  std::vector<std::vector<int64_t>> out(B);
  std::vector<bool> done(B, false);
  std::vector<int64_t> seq;  // (B, i) row-major
  for (int64_t i = 0; i < n_max; ++i) {
    const Tensor codes = Tensor::from_vector(seq, {B, i});
    const Tensor logits = model.forward(text, codes).data().select(1, i).to(DType::f32).contiguous();  // (B, V)
    const std::vector<float> u = rand_uniform({B}, gen).to_vector<float>();
    const bool allow_end = opt.tokens == 0 && i > 0;
    std::vector<int64_t> next(B);
    for (int64_t b = 0; b < B; ++b) {
      const int64_t c = sample_from_logits(logits.data<float>() + b * V, V, opt.temperature, opt.top_k, allow_end,
                                           (double)u[b]);
      if (!done[b]) {
        if (c == end) done[b] = true;
        else out[b].push_back(c);
      }
      next[b] = c == end ? 0 : c;  // finished rows are fed a dummy code; their draws are discarded
    }
    if (std::all_of(done.begin(), done.end(), [](bool d) { return d; })) break;
    std::vector<int64_t> grown(B * (i + 1));
    for (int64_t b = 0; b < B; ++b) {
      std::copy(seq.begin() + b * i, seq.begin() + (b + 1) * i, grown.begin() + b * (i + 1));
      grown[b * (i + 1) + i] = next[b];
    }
    seq.swap(grown);
  }
  return out;
}

}  // namespace t2m::casim
