// ops_activation.cpp — forward/backward pairs of gelu_tanh (fused kernel), silu (one pass each way, OpenMP over
// large tensors) and inverted dropout (Philox mask saved for the backward).
#include "autograd/ops_activation.h"

#include <cmath>
#include <string>

#include "autograd/node.h"
#include "tensor/fused/gelu_tanh.h"
#include "tensor/ops.h"
#include "tensor/parallel.h"

namespace t2m::ag {

namespace {

void check_float(const char* op, const Variable& x) {
  if (x.dtype() != DType::f32 && x.dtype() != DType::f64)
    throw Error(std::string(op) + ": x must be f32 or f64, got " + dtype_name(x.dtype()) + " " +
                shape_str(x.shape()));
}

int threads_for(int64_t n) { return n < kParallelGrain ? 1 : get_num_threads(); }

// y = x * s, s = 1 / (1 + exp(-x))
template <typename T>
void silu_forward(T* y, const T* x, int64_t n) {
#pragma omp parallel for schedule(static) num_threads(threads_for(n))
  for (int64_t i = 0; i < n; ++i) y[i] = x[i] / ((T)1 + std::exp(-x[i]));
}

// dx = g * s * (1 + x * (1 - s))
template <typename T>
void silu_backward(T* dx, const T* g, const T* x, int64_t n) {
#pragma omp parallel for schedule(static) num_threads(threads_for(n))
  for (int64_t i = 0; i < n; ++i) {
    const T s = (T)1 / ((T)1 + std::exp(-x[i]));
    dx[i] = g[i] * s * ((T)1 + x[i] * ((T)1 - s));
  }
}

}  // namespace

// x (n) -> y (n); x saved.  dx = g * gelu'(x) (fused kernel).
Variable gelu_tanh(const Variable& x) {
  check_float("gelu_tanh", x);
  const Tensor xc = x.data().contiguous();
  const int64_t n = xc.numel();
  Tensor y = Tensor::empty(xc.shape(), xc.dtype());
  if (n > 0) {
    if (xc.dtype() == DType::f32)
      fused::gelu_tanh_forward<float>(y.data<float>(), xc.data<float>(), n);
    else
      fused::gelu_tanh_forward<double>(y.data<double>(), xc.data<double>(), n);
  }
  return record("gelu_tanh", y, {x}, [xc, n](const Tensor& grad, const std::vector<bool>&) {
    const Tensor g = grad.contiguous();
    Tensor dx = Tensor::empty(xc.shape(), xc.dtype());
    if (n == 0) return std::vector<Tensor>{dx};
    if (xc.dtype() == DType::f32)
      fused::gelu_tanh_backward<float>(dx.data<float>(), g.data<float>(), xc.data<float>(), n);
    else
      fused::gelu_tanh_backward<double>(dx.data<double>(), g.data<double>(), xc.data<double>(), n);
    return std::vector<Tensor>{dx};
  });
}

// x (n) -> y (n); x saved.
Variable silu(const Variable& x) {
  check_float("silu", x);
  const Tensor xc = x.data().contiguous();
  const int64_t n = xc.numel();
  Tensor y = Tensor::empty(xc.shape(), xc.dtype());
  if (n > 0) {
    if (xc.dtype() == DType::f32)
      silu_forward<float>(y.data<float>(), xc.data<float>(), n);
    else
      silu_forward<double>(y.data<double>(), xc.data<double>(), n);
  }
  return record("silu", y, {x}, [xc, n](const Tensor& grad, const std::vector<bool>&) {
    const Tensor g = grad.contiguous();
    Tensor dx = Tensor::empty(xc.shape(), xc.dtype());
    if (n == 0) return std::vector<Tensor>{dx};
    if (xc.dtype() == DType::f32)
      silu_backward<float>(dx.data<float>(), g.data<float>(), xc.data<float>(), n);
    else
      silu_backward<double>(dx.data<double>(), g.data<double>(), xc.data<double>(), n);
    return std::vector<Tensor>{dx};
  });
}

// x (n) -> y (n) = x * m, m = bernoulli(1 - p) / (1 - p); m saved.  dx = g * m.
Variable dropout(const Variable& x, double p, Generator& gen, bool training) {
  check_float("dropout", x);
  if (!(p >= 0.0 && p <= 1.0))
    throw Error("dropout: p must be in [0, 1], got " + std::to_string(p) + " (x " + shape_str(x.shape()) + ")");
  if (!training || p == 0.0) return x;
  Tensor mask = rand_bernoulli(x.shape(), gen, 1.0 - p, x.dtype());
  mul_(mask, p < 1.0 ? 1.0 / (1.0 - p) : 0.0);
  Tensor y = mul(x.data(), mask);
  return record("dropout", y, {x}, [mask](const Tensor& g, const std::vector<bool>&) {
    return std::vector<Tensor>{mul(g, mask)};
  });
}

}  // namespace t2m::ag
