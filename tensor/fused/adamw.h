// adamw.h — fused multi-tensor AdamW step (Loshchilov & Hutter 2019, Algorithm 2): decoupled weight decay and
// bias-corrected moments, the same update order as torch.optim.AdamW:
//   p <- p * (1 - lr * weight_decay)
//   m <- beta1 m + (1 - beta1) g;   v <- beta2 v + (1 - beta2) g^2
//   p <- p - lr * (m / (1 - beta1^step)) / (sqrt(v / (1 - beta2^step)) + eps)
// `step` is the 1-based count of this update (the first call uses step = 1). float only.
// All tensors are walked as one flattened range split evenly across threads (no allocation; small tensors do
// not unbalance the threads). Elementwise, hence bitwise independent of the thread count.
// Errors: t2m::Error for step < 1, lr/eps/weight_decay < 0, betas outside [0, 1), n_tensors < 0, a negative
// size, a null pointer for a tensor of size > 0.
#pragma once
#include <cstdint>

namespace t2m::fused {

struct AdamWConfig {
  float lr = 1e-3f;
  float beta1 = 0.9f;
  float beta2 = 0.999f;
  float eps = 1e-8f;
  float weight_decay = 1e-2f;
};

// params/grads/m/v: n_tensors pointers, tensor i has sizes[i] floats. params, m, v updated in place.
void adamw_step(float* const* params, const float* const* grads, float* const* m, float* const* v,
                const int64_t* sizes, int64_t n_tensors, const AdamWConfig& cfg, int64_t step);

// One contiguous parameter buffer (llm.c style): p, g, m, v (n).
void adamw_step(float* params, const float* grads, float* m, float* v, int64_t n, const AdamWConfig& cfg,
                int64_t step);

}  // namespace t2m::fused
