// adamw.cpp — each thread takes a contiguous slice [lo, hi) of the concatenation of all tensors and walks the
// tensors that overlap it.
#include "tensor/fused/adamw.h"

#include <omp.h>

#include <cmath>
#include <string>

#include "tensor/fused/kernel_util.h"

namespace t2m::fused {

namespace {

struct AdamWCoef {
  float lr, b1, b2, eps, decay, bc1, bc2;
};

inline void adamw_range(float* __restrict p, const float* __restrict g, float* __restrict m, float* __restrict v,
                        int64_t n, const AdamWCoef& c) {
  const float omb1 = 1.0f - c.b1, omb2 = 1.0f - c.b2;
#pragma omp simd
  for (int64_t i = 0; i < n; ++i) {
    const float gi = g[i];
    const float mi = c.b1 * m[i] + omb1 * gi;
    const float vi = c.b2 * v[i] + omb2 * gi * gi;
    m[i] = mi;
    v[i] = vi;
    const float mhat = mi / c.bc1;
    const float vhat = vi / c.bc2;
    p[i] = p[i] * c.decay - c.lr * mhat / (std::sqrt(vhat) + c.eps);
  }
}

AdamWCoef make_coef(const AdamWConfig& cfg, int64_t step) {
  if (step < 1) throw Error("adamw_step: step must be >= 1 (1-based), got " + std::to_string(step));
  if (!(cfg.lr >= 0) || !(cfg.eps >= 0) || !(cfg.weight_decay >= 0))
    throw Error("adamw_step: lr, eps and weight_decay must be >= 0, got lr=" + std::to_string(cfg.lr) +
                " eps=" + std::to_string(cfg.eps) + " weight_decay=" + std::to_string(cfg.weight_decay));
  if (!(cfg.beta1 >= 0 && cfg.beta1 < 1) || !(cfg.beta2 >= 0 && cfg.beta2 < 1))
    throw Error("adamw_step: betas must be in [0, 1), got beta1=" + std::to_string(cfg.beta1) +
                " beta2=" + std::to_string(cfg.beta2));
  AdamWCoef c;
  c.lr = cfg.lr;
  c.b1 = cfg.beta1;
  c.b2 = cfg.beta2;
  c.eps = cfg.eps;
  c.decay = 1.0f - cfg.lr * cfg.weight_decay;
  c.bc1 = (float)(1.0 - std::pow((double)cfg.beta1, (double)step));
  c.bc2 = (float)(1.0 - std::pow((double)cfg.beta2, (double)step));
  return c;
}

}  // namespace

void adamw_step(float* const* params, const float* const* grads, float* const* m, float* const* v,
                const int64_t* sizes, int64_t n_tensors, const AdamWConfig& cfg, int64_t step) {
  const AdamWCoef c = make_coef(cfg, step);
  check_dim("adamw_step", "n_tensors", n_tensors, 0);
  if (n_tensors == 0) return;
  check_ptr("adamw_step", "params", params);
  check_ptr("adamw_step", "grads", grads);
  check_ptr("adamw_step", "m", m);
  check_ptr("adamw_step", "v", v);
  check_ptr("adamw_step", "sizes", sizes);
  int64_t total = 0;
  for (int64_t i = 0; i < n_tensors; ++i) {
    if (sizes[i] < 0)
      throw Error("adamw_step: tensor " + std::to_string(i) + " has negative size " + std::to_string(sizes[i]));
    if (sizes[i] > 0 && (!params[i] || !grads[i] || !m[i] || !v[i]))
      throw Error("adamw_step: tensor " + std::to_string(i) + " has a null param/grad/m/v pointer");
    total += sizes[i];
  }
  const int nt = fused_threads(total);
#pragma omp parallel num_threads(nt) if (nt > 1)
  {
    const auto [lo, hi] = row_range(total, omp_get_thread_num(), omp_get_num_threads());
    int64_t base = 0;
    for (int64_t i = 0; i < n_tensors && base < hi; ++i) {
      const int64_t b0 = base, b1 = base + sizes[i];
      base = b1;
      const int64_t s0 = b0 > lo ? b0 : lo, s1 = b1 < hi ? b1 : hi;
      if (s1 <= s0) continue;
      const int64_t off = s0 - b0;
      adamw_range(params[i] + off, grads[i] + off, m[i] + off, v[i] + off, s1 - s0, c);
    }
  }
}

void adamw_step(float* params, const float* grads, float* m, float* v, int64_t n, const AdamWConfig& cfg,
                int64_t step) {
  check_dim("adamw_step", "n", n, 0);
  adamw_step(&params, &grads, &m, &v, &n, 1, cfg, step);
}

}  // namespace t2m::fused
