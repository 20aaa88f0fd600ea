// ops_activation.cpp — forward/backward pairs of gelu_tanh (fused kernel), silu (one pass each way, OpenMP over
// large tensors), inverted dropout (one fused Philox pass; a byte mask saved for the backward) and the residual
// form x + dropout(h) (the same pass adding x).
#include "autograd/ops_activation.h"

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>

#include "autograd/bit_mask.h"
#include "autograd/node.h"
#include "autograd/ops_elementwise.h"
#include "tensor/fused/gelu_tanh.h"
#include "tensor/parallel.h"
#include "tensor/rng.h"

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

// keep[j] = (u_j < pkeep) with u_j the rand_bernoulli uniform of element j (Philox block base + j/4, word j%4);
// y[j] = keep[j] ? x[j] * scale : 0, for j < n <= 4 * kDropChunk (one batch of Philox blocks), serially.
constexpr int64_t kDropChunk = 64;  // Philox blocks generated at once (philox4x32_blocks)
template <typename T>
void dropout_chunk(T* y, uint8_t* keep, const T* x, int64_t n, uint64_t seed, uint64_t base, double pkeep, T scale) {
  uint32_t w[4 * kDropChunk];
  philox4x32_blocks(seed, base, (n + 3) / 4, w);
  // u_j = w_j 2^-32 < pkeep  <=>  w_j < ceil(pkeep 2^32) (exact: w_j is an integer, the scaling a power of two);
  // an integer compare vectorises where the double one does not.
  const double lim = std::ceil(pkeep * 4294967296.0);
  if (lim > 4294967295.0) {
    for (int64_t j = 0; j < n; ++j) {
      keep[j] = 1;
      y[j] = x[j] * scale;
    }
    return;
  }
  const uint32_t thresh = (uint32_t)(lim > 0.0 ? lim : 0.0);
  // Branch-free (vectorises): the dropped elements' bits are masked to +0, as `k ? x * scale : 0` gives.
  for (int64_t j = 0; j < n; ++j) {
    const bool k = w[j] < thresh;
    keep[j] = k;
    y[j] = keep_or_zero(x[j] * scale, k);
  }
}

// The chunks of dropout_chunk over threads. Blocks are independent, so any thread split gives the same mask.
template <typename Chunk>
void for_dropout_chunks(int64_t n, Chunk chunk) {
  constexpr int64_t kElems = 4 * kDropChunk;
  const int64_t nch = (n + kElems - 1) / kElems;
#pragma omp parallel for schedule(static) num_threads(threads_for(n))
  for (int64_t ch = 0; ch < nch; ++ch) chunk(ch * kElems, n - ch * kElems < kElems ? n - ch * kElems : kElems);
}

template <typename T>
void dropout_forward(T* y, uint8_t* keep, const T* x, int64_t n, uint64_t seed, uint64_t base, double pkeep,
                     T scale) {
  for_dropout_chunks(n, [&](int64_t j0, int64_t m) {
    dropout_chunk(y + j0, keep + j0, x + j0, m, seed, base + (uint64_t)j0 / 4, pkeep, scale);
  });
}

// residual_dropout's forward: y = x + d with d as dropout_chunk writes it (each chunk's d staged in a buffer first,
// so that the compiler cannot contract x + h * scale into an FMA and round differently from add(x, dropout(h))).
template <typename T>
void residual_dropout_forward(T* y, uint8_t* keep, const T* x, const T* h, int64_t n, uint64_t seed, uint64_t base,
                              double pkeep, T scale) {
  for_dropout_chunks(n, [&](int64_t j0, int64_t m) {
    T d[4 * kDropChunk];
    dropout_chunk(d, keep + j0, h + j0, m, seed, base + (uint64_t)j0 / 4, pkeep, scale);
    for (int64_t j = 0; j < m; ++j) y[j0 + j] = x[j0 + j] + d[j];
  });
}

// dx[j] = keep[j] ? g[j] * scale : 0
template <typename T>
void dropout_backward(T* dx, const T* g, const uint8_t* keep, int64_t n, T scale) {
#pragma omp parallel for schedule(static) num_threads(threads_for(n))
  for (int64_t j = 0; j < n; ++j)  // keep[j] is 0 or 1: masks the dropped elements' bits to +0, branch-free
    dx[j] = keep_or_zero(g[j] * scale, keep[j] != 0);
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

namespace {

void check_p(const char* op, double p, const Variable& x) {
  if (!(p >= 0.0 && p <= 1.0))
    throw Error(std::string(op) + ": p must be in [0, 1], got " + std::to_string(p) + " (x " + shape_str(x.shape()) +
                ")");
}

// The mask draw of both dropout forms over n elements: the generator advanced as rand_bernoulli would, the scale
// 1 / (1 - p) and the keep-byte storage for the backward.
struct DropDraw {
  uint64_t base;
  double scale;
  std::shared_ptr<Storage> keep;
  uint8_t* mask() const { return static_cast<uint8_t*>(keep->data); }
};
DropDraw draw_dropout(Generator& gen, int64_t n, double p) {
  return {gen.advance((uint64_t)(n + 3) / 4), p < 1.0 ? 1.0 / (1.0 - p) : 0.0,
          std::make_shared<Storage>((size_t)(n > 0 ? n : 1))};
}

// The backward of both dropout forms: the gradient through the mask, g * keep / (1 - p).
Tensor dropout_grad(const Tensor& grad, const std::shared_ptr<Storage>& keep, int64_t n, double scale) {
  const Tensor g = grad.contiguous();
  Tensor dx = Tensor::empty(g.shape(), g.dtype());
  const uint8_t* km = static_cast<const uint8_t*>(keep->data);
  if (n == 0) return dx;
  if (g.dtype() == DType::f32)
    dropout_backward<float>(dx.data<float>(), g.data<float>(), km, n, (float)scale);
  else
    dropout_backward<double>(dx.data<double>(), g.data<double>(), km, n, scale);
  return dx;
}

}  // namespace

// x (n) -> y (n) = x * keep / (1 - p); the keep mask (one byte per element, allocator memory) saved.
// dx = g * keep / (1 - p).
Variable dropout(const Variable& x, double p, Generator& gen, bool training) {
  check_float("dropout", x);
  check_p("dropout", p, x);
  if (!training || p == 0.0) return x;
  const Tensor xc = x.data().contiguous();
  const int64_t n = xc.numel();
  const DropDraw d = draw_dropout(gen, n, p);
  Tensor y = Tensor::empty(xc.shape(), xc.dtype());
  if (n > 0) {
    if (xc.dtype() == DType::f32)
      dropout_forward<float>(y.data<float>(), d.mask(), xc.data<float>(), n, gen.seed(), d.base, 1.0 - p,
                             (float)d.scale);
    else
      dropout_forward<double>(y.data<double>(), d.mask(), xc.data<double>(), n, gen.seed(), d.base, 1.0 - p,
                              d.scale);
  }
  return record("dropout", y, {x}, [d, n](const Tensor& grad, const std::vector<bool>&) {
    return std::vector<Tensor>{dropout_grad(grad, d.keep, n, d.scale)};
  });
}

// x (n), h (n) -> y (n) = x + h * keep / (1 - p) in one pass; the keep mask saved. dx = g, dh = g * keep / (1 - p).
Variable residual_dropout(const Variable& x, const Variable& h, double p, Generator& gen, bool training) {
  check_float("residual_dropout", h);
  check_p("residual_dropout", p, h);
  if (!training || p == 0.0 || x.shape() != h.shape() || x.dtype() != h.dtype())
    return add(x, dropout(h, p, gen, training));
  const Tensor xc = x.data().contiguous(), hc = h.data().contiguous();
  const int64_t n = hc.numel();
  const DropDraw d = draw_dropout(gen, n, p);  // as dropout(h) draws it
  Tensor y = Tensor::empty(hc.shape(), hc.dtype());
  if (n > 0) {
    if (hc.dtype() == DType::f32)
      residual_dropout_forward<float>(y.data<float>(), d.mask(), xc.data<float>(), hc.data<float>(), n, gen.seed(),
                                      d.base, 1.0 - p, (float)d.scale);
    else
      residual_dropout_forward<double>(y.data<double>(), d.mask(), xc.data<double>(), hc.data<double>(), n,
                                       gen.seed(), d.base, 1.0 - p, d.scale);
  }
  const Shape X = x.shape();
  return record("residual_dropout", y, {x, h}, [d, n, X](const Tensor& grad, const std::vector<bool>& need) {
    return std::vector<Tensor>{need[0] ? reduce_grad_to(grad, X) : Tensor(),
                               need[1] ? dropout_grad(grad, d.keep, n, d.scale) : Tensor()};
  });
}

}  // namespace t2m::ag
