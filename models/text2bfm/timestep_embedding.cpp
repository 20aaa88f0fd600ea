// timestep_embedding.cpp — sinusoidal time features and the two-layer time MLP.
#include "models/text2bfm/timestep_embedding.h"

#include <cmath>
#include <string>

#include "autograd/ops_activation.h"

namespace t2m::text2bfm {

namespace {

template <typename T>
void fill_embedding(T* out, const T* t, int64_t B, int64_t half, double max_period) {
  // The anchor's arithmetic, step by step in T: f_i = exp((-ln(max_period) * i) / half), a = (t * 1000) * f_i
  // (in float32 a differs from a double-precision angle by ~1 ulp of 1000 t, which cos/sin then see).
  const T neg_log = (T)(-std::log(max_period));
  for (int64_t b = 0; b < B; ++b)
    for (int64_t i = 0; i < half; ++i) {
      const T f = std::exp(neg_log * (T)i / (T)half);
      const T a = t[b] * (T)1000 * f;
      out[b * 2 * half + i] = std::cos(a);
      out[b * 2 * half + half + i] = std::sin(a);
    }
}

}  // namespace

// t (B) -> (B, dim): [cos(1000 t f), sin(1000 t f)]
Tensor timestep_embedding(const Tensor& t, int64_t dim, double max_period) {
  if (t.dim() != 1) throw Error("timestep_embedding: t must be 1-D (B), got " + shape_str(t.shape()));
  if (dim < 2 || dim % 2 != 0) throw Error("timestep_embedding: dim must be even and >= 2, got " + std::to_string(dim));
  if (t.dtype() != DType::f32 && t.dtype() != DType::f64)
    throw Error(std::string("timestep_embedding: t must be float32 or float64, got ") + dtype_name(t.dtype()));
  const Tensor tc = t.contiguous();
  const int64_t B = t.size(0);
  Tensor out = Tensor::empty({B, dim}, t.dtype());
  if (t.dtype() == DType::f32)
    fill_embedding<float>(out.data<float>(), tc.data<float>(), B, dim / 2, max_period);
  else
    fill_embedding<double>(out.data<double>(), tc.data<double>(), B, dim / 2, max_period);
  return out;
}

TimestepMLP::TimestepMLP(int64_t freq_dim, int64_t width, Generator& gen) : freq_dim_(freq_dim) {
  fc0_ = register_module("0", std::make_shared<nn::Linear>(freq_dim, width, true, gen));
  fc2_ = register_module("2", std::make_shared<nn::Linear>(width, width, true, gen));
}

// t (B) -> (B, width)
ag::Variable TimestepMLP::forward(const Tensor& t) const {
  const Tensor e = timestep_embedding(t, freq_dim_).to(fc0_->weight().dtype());
  return fc2_->forward(ag::silu(fc0_->forward(ag::Variable(e))));
}

}  // namespace t2m::text2bfm
