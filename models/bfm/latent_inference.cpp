// latent_inference.cpp — Eq 2 window means by a sliding sum (add b_{t+H-1}... computed backward from the end).
#include "models/bfm/latent_inference.h"

#include <cmath>
#include <string>
#include <vector>

#include "models/bfm/sphere_projection.h"

namespace t2m::bfm {

// b [n, d] -> z [n, d]
Tensor tracking_latents(const Tensor& b, int L) {
  if (b.dim() != 2 || b.size(0) < 1 || b.size(1) < 1)
    throw Error("tracking_latents: embeddings must be [n >= 1, d >= 1], got " + shape_str(b.shape()));
  if (L < 1) throw Error("tracking_latents: window L must be >= 1, got " + std::to_string(L));
  if (b.dtype() != DType::f32 && b.dtype() != DType::f64)
    throw Error(std::string("tracking_latents: embeddings must be f32 or f64, got ") + dtype_name(b.dtype()));
  const int64_t n = b.size(0), d = b.size(1);
  const Tensor b64 = b.to(DType::f64).contiguous();
  const double* x = b64.data<double>();
  Tensor mean = Tensor::empty({n, d}, DType::f64);
  double* m = mean.data<double>();
  // Walk t from the end: window [t, t + H_t), H_t = min(L, n - t). Going from t + 1 to t adds row t and, once the
  // window is full (t + L < n... i.e. t + L <= n - 1), drops row t + L.
  std::vector<double> s(d, 0.0);
  for (int64_t t = n - 1; t >= 0; --t) {
    for (int64_t k = 0; k < d; ++k) s[k] += x[t * d + k];
    if (t + L < n)
      for (int64_t k = 0; k < d; ++k) s[k] -= x[(t + L) * d + k];
    const double H = (double)std::min<int64_t>(L, n - t);
    for (int64_t k = 0; k < d; ++k) m[t * d + k] = s[k] / H;
  }
  return project_rows(mean, std::sqrt((double)d)).to(b.dtype());
}

}  // namespace t2m::bfm
