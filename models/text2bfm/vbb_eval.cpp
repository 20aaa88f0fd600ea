// vbb_eval.cpp — windowed reconstruction of a latent set and its two scores (see vbb_eval.h).
#include "models/text2bfm/vbb_eval.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "autograd/no_grad.h"
#include "models/text2bfm/program_dataset.h"

namespace t2m::text2bfm {
namespace {

[[noreturn]] void fail(const std::string& m) { throw Error("vbb eval: " + m); }

struct Window {
  int c;
  int64_t t0, len;
};

}  // namespace

nlohmann::json VbbEvalResult::to_json() const {
  return {{"latent_mse", latent_mse}, {"action_kl", std::isfinite(action_kl) ? nlohmann::json(action_kl) : nullptr},
          {"frames", frames},         {"windows", windows},
          {"clips", clips}};
}

VbbEvalResult evaluate_reconstruction(const LatentSet& set, int64_t window, bfm::FbAgent* agent,
                                      const LatentReconstructor& reconstruct, int64_t batch) {
  if (set.clips() == 0) fail("empty latent set");
  if (window < 1 || batch < 1) fail("window and batch must be >= 1");
  const int64_t d = set.z_dim, S = set.obs_dim;
  std::vector<Window> wins;
  for (int c = 0; c < set.clips(); ++c)
    for (int64_t t0 = 0; t0 < set.frames(c); t0 += window) wins.push_back({c, t0, std::min(window, set.frames(c) - t0)});
  double se = 0, kl = 0;
  int64_t frames = 0;
  const double sigma = agent ? (double)agent->config().actor_std : 1.0;
  for (size_t w0 = 0; w0 < wins.size(); w0 += (size_t)batch) {
    const int64_t B = std::min<int64_t>(batch, (int64_t)(wins.size() - w0));
    Tensor z = Tensor::empty({B, window, d});
    float* zp = z.data<float>();
    for (int64_t b = 0; b < B; ++b) {
      const Window& w = wins[w0 + b];
      for (int64_t t = 0; t < window; ++t)
        std::copy_n(set.z_at(w.c, w.t0 + std::min(t, w.len - 1)), d, zp + (b * window + t) * d);
    }
    const Tensor zh = reconstruct(z).contiguous();
    if (zh.shape() != z.shape()) fail("the reconstruction has shape " + shape_str(zh.shape()) + ", expected " +
                                      shape_str(z.shape()));
    const float* hp = zh.data<float>();
    // Real frames only: [N, d] latents and [N, S] states for the actor.
    int64_t N = 0;
    for (int64_t b = 0; b < B; ++b) N += wins[w0 + b].len;
    Tensor zr = Tensor::empty({N, d}), hr = Tensor::empty({N, d}), sr = Tensor::empty({N, S});
    float *zrp = zr.data<float>(), *hrp = hr.data<float>(), *srp = sr.data<float>();
    int64_t n = 0;
    for (int64_t b = 0; b < B; ++b) {
      const Window& w = wins[w0 + b];
      for (int64_t t = 0; t < w.len; ++t, ++n) {
        std::copy_n(zp + (b * window + t) * d, d, zrp + n * d);
        std::copy_n(hp + (b * window + t) * d, d, hrp + n * d);
        std::copy_n(set.state_at(w.c, w.t0 + t), S, srp + n * S);
        for (int64_t k = 0; k < d; ++k) {
          const double e = (double)zrp[n * d + k] - (double)hrp[n * d + k];
          se += e * e;
        }
      }
    }
    if (agent) {  // Eq 21 with the fixed policy std: Σ_a (μ̂ − μ)² / (2σ²) per frame
      const Tensor mh = agent->actor_mean(sr, hr).contiguous(), m = agent->actor_mean(sr, zr).contiguous();
      const float *a = mh.data<float>(), *r = m.data<float>();
      for (int64_t i = 0; i < mh.numel(); ++i) kl += ((double)a[i] - r[i]) * ((double)a[i] - r[i]) / (2 * sigma * sigma);
    }
    frames += N;
  }
  VbbEvalResult res;
  res.frames = frames;
  res.windows = (int64_t)wins.size();
  res.clips = set.clips();
  res.latent_mse = se / (double)frames;
  res.action_kl = agent ? kl / (double)frames : std::numeric_limits<double>::quiet_NaN();
  return res;
}

Tensor project_rows_to_sphere(const Tensor& z) {
  Tensor out = z.contiguous().clone();
  const int64_t d = out.size(out.dim() - 1), n = out.numel() / std::max<int64_t>(d, 1);
  const double radius = std::sqrt((double)d);
  float* p = out.data<float>();
  for (int64_t r = 0; r < n; ++r) {
    double norm = 0;
    for (int64_t k = 0; k < d; ++k) norm += (double)p[r * d + k] * p[r * d + k];
    if (norm <= 0) continue;
    const double s = radius / std::sqrt(norm);
    for (int64_t k = 0; k < d; ++k) p[r * d + k] = (float)(p[r * d + k] * s);
  }
  return out;
}

// z (T, d) -> programs (Tm, latent) -> D_θ -> (Tm c, d) -> first T rows -> Proj.
Tensor reconstruct_clip_latents(const Vbb& vbb, const Tensor& z) {
  const Tensor m = encode_programs(vbb, {z})[0];
  ag::NoGradGuard ng;
  Generator unused(0);
  const Tensor zh = vbb.decode(ag::Variable(m.transpose(0, 1).unsqueeze(0).contiguous()), unused).data();  // (1,Tp,d)
  return project_rows_to_sphere(zh.select(0, 0).narrow(0, 0, z.size(0)));
}

// Table 4 columns for a trained VBB: ẑ = D_θ(μ_φ(z)) (then Proj when `project`).
VbbEvalResult evaluate_vbb(Vbb& vbb, const LatentSet& set, int64_t window, bfm::FbAgent* agent, int64_t batch,
                           bool project) {
  const VbbConfig& cfg = vbb.config();
  if (window % cfg.compression() != 0)
    fail("window " + std::to_string(window) + " is not a multiple of the compression " +
         std::to_string(cfg.compression()));
  if (set.z_dim != cfg.in_dim) fail("latent set z_dim " + std::to_string(set.z_dim) + " != VBB in_dim " +
                                    std::to_string(cfg.in_dim));
  const bool was_training = vbb.is_training();
  vbb.eval();
  Generator unused(0);
  const auto rec = [&](const Tensor& z) {
    ag::NoGradGuard ng;
    const VbbPosterior q = vbb.encode(ag::Variable(z), unused);
    const Tensor zh = vbb.decode(q.mu, unused).data();
    return project ? project_rows_to_sphere(zh) : zh;
  };
  VbbEvalResult r = evaluate_reconstruction(set, window, agent, rec, batch);
  vbb.train(was_training);
  return r;
}

// The "average pooling" row: program frame = Proj(mean of c latents) (or the plain mean), decoded by repetition.
VbbEvalResult evaluate_average_pooling(const LatentSet& set, int64_t compression, int64_t window,
                                       bfm::FbAgent* agent, int64_t batch, bool project) {
  if (compression < 1 || window % compression != 0)
    fail("window " + std::to_string(window) + " is not a multiple of the compression " + std::to_string(compression));
  const int64_t d = set.z_dim;
  const double radius = std::sqrt((double)d);
  const auto rec = [&](const Tensor& z) {
    const int64_t B = z.size(0), W = z.size(1);
    Tensor out = Tensor::empty(z.shape());
    const float* zp = z.data<float>();
    float* op = out.data<float>();
    std::vector<double> m(d);
    for (int64_t b = 0; b < B; ++b)
      for (int64_t j = 0; j < W / compression; ++j) {
        std::fill(m.begin(), m.end(), 0.0);
        for (int64_t t = j * compression; t < (j + 1) * compression; ++t)
          for (int64_t k = 0; k < d; ++k) m[k] += zp[(b * W + t) * d + k];
        double norm = 0;
        for (double v : m) norm += v * v;
        const double s = project ? radius / std::max(std::sqrt(norm), 1e-12) : 1.0 / (double)compression;
        for (int64_t t = j * compression; t < (j + 1) * compression; ++t)
          for (int64_t k = 0; k < d; ++k) op[(b * W + t) * d + k] = (float)(m[k] * s);
      }
    return out;
  };
  return evaluate_reconstruction(set, window, agent, rec, batch);
}

}  // namespace t2m::text2bfm
