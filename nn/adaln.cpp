// adaln.cpp — modulate and gated_residual as single forward/backward ops (one pass over (B, T, D) each way),
// and the AdaLN module (SiLU -> Linear -> chunk).
#include "nn/adaln.h"

#include <cmath>
#include <string>

#include "autograd/node.h"
#include "autograd/ops_join.h"
#include "autograd/ops_activation.h"
#include "nn/linear.h"
#include "tensor/parallel.h"

namespace t2m::nn {

namespace {

int threads_for(int64_t work) { return work < kParallelGrain ? 1 : std::max(1, get_num_threads()); }

// Checks x (B, T, D), a and b (B, D) [b may be undefined], y (B, T, D) or undefined; returns {B, T, D}.
Shape check_btd(const char* op, const Tensor& x, const Tensor& a, const Tensor& b, const Tensor& y) {
  auto fail = [&](const std::string& what) {
    std::string m = std::string(op) + ": " + what + " (x " + shape_str(x.shape()) + ", " + shape_str(a.shape());
    if (b.defined()) m += ", " + shape_str(b.shape());
    if (y.defined()) m += ", y " + shape_str(y.shape());
    throw Error(m + ")");
  };
  if (x.dim() != 3) fail("x must be (B, T, D)");
  const Shape bd{x.size(0), x.size(2)};
  if (a.shape() != bd || (b.defined() && b.shape() != bd)) fail("conditioning must be (B, D) = " + shape_str(bd));
  if (y.defined() && y.shape() != x.shape()) fail("y must have x's shape");
  const DType dt = x.dtype();
  if ((dt != DType::f32 && dt != DType::f64) || a.dtype() != dt || (b.defined() && b.dtype() != dt) ||
      (y.defined() && y.dtype() != dt))
    fail("operands must share a float dtype");
  return x.shape();
}

// out[b,t,:] = x[b,t,:] * (1 + scale[b,:]) + shift[b,:]
template <typename T>
void modulate_fwd(T* out, const T* x, const T* shift, const T* scale, int64_t B, int64_t Tn, int64_t D) {
  const int nt = threads_for(B * Tn * D);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t r = 0; r < B * Tn; ++r) {
    const T* sh = shift + (r / Tn) * D;
    const T* sc = scale + (r / Tn) * D;
    for (int64_t c = 0; c < D; ++c) out[r * D + c] = x[r * D + c] * ((T)1 + sc[c]) + sh[c];
  }
}

// dx = g * (1 + scale); dshift[b] = sum_t g[b,t]; dscale[b] = sum_t g[b,t] * x[b,t]. Any output may be null.
// One loop per output, so each vectorises (one loop with all three under ifs ran scalar).
template <typename T>
void modulate_bwd(T* dx, T* dshift, T* dscale, const T* g, const T* x, const T* scale, int64_t B, int64_t Tn,
                  int64_t D) {
  const int nt = threads_for(B * Tn * D);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t b = 0; b < B; ++b) {
    const T* sc = scale + b * D;
    const T* gb = g + b * Tn * D;
    if (dx)
      for (int64_t t = 0; t < Tn; ++t) {
        const T* gr = gb + t * D;
        T* o = dx + (b * Tn + t) * D;
#pragma omp simd
        for (int64_t c = 0; c < D; ++c) o[c] = gr[c] * ((T)1 + sc[c]);
      }
    if (dshift) {
      T* o = dshift + b * D;
      for (int64_t c = 0; c < D; ++c) o[c] = 0;
      for (int64_t t = 0; t < Tn; ++t) {
        const T* gr = gb + t * D;
#pragma omp simd
        for (int64_t c = 0; c < D; ++c) o[c] += gr[c];
      }
    }
    if (dscale) {
      T* o = dscale + b * D;
      const T* xb = x + b * Tn * D;
      for (int64_t c = 0; c < D; ++c) o[c] = 0;
      for (int64_t t = 0; t < Tn; ++t) {
        const T* gr = gb + t * D;
        const T* xr = xb + t * D;
#pragma omp simd
        for (int64_t c = 0; c < D; ++c) o[c] += gr[c] * xr[c];
      }
    }
  }
}

// out[b,t,:] = x[b,t,:] + gate[b,:] * y[b,t,:]
template <typename T>
void gated_fwd(T* out, const T* x, const T* gate, const T* y, int64_t B, int64_t Tn, int64_t D) {
  const int nt = threads_for(B * Tn * D);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t r = 0; r < B * Tn; ++r) {
    const T* gt = gate + (r / Tn) * D;
    for (int64_t c = 0; c < D; ++c) out[r * D + c] = x[r * D + c] + gt[c] * y[r * D + c];
  }
}

// dy = g * gate; dgate[b] = sum_t g[b,t] * y[b,t] (dx = g is passed through by the caller). Outputs may be null.
template <typename T>
void gated_bwd(T* dy, T* dgate, const T* g, const T* gate, const T* y, int64_t B, int64_t Tn, int64_t D) {
  const int nt = threads_for(B * Tn * D);
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
  for (int64_t b = 0; b < B; ++b) {
    const T* gt = gate + b * D;
    if (dy)
      for (int64_t t = 0; t < Tn; ++t) {
        const int64_t r = (b * Tn + t) * D;
#pragma omp simd
        for (int64_t c = 0; c < D; ++c) dy[r + c] = g[r + c] * gt[c];
      }
    if (dgate) {
      T* dg = dgate + b * D;
      for (int64_t c = 0; c < D; ++c) dg[c] = 0;
      for (int64_t t = 0; t < Tn; ++t) {
        const int64_t r = (b * Tn + t) * D;
#pragma omp simd
        for (int64_t c = 0; c < D; ++c) dg[c] += g[r + c] * y[r + c];
      }
    }
  }
}

template <typename T>
T* ptr(Tensor& t) {
  return t.defined() ? t.data<T>() : nullptr;
}

}  // namespace

// x (B,T,D), shift/scale (B,D) -> (B,T,D)
ag::Variable modulate(const ag::Variable& x, const ag::Variable& shift, const ag::Variable& scale) {
  const Shape s = check_btd("modulate", x.data(), shift.data(), scale.data(), Tensor());
  const int64_t B = s[0], Tn = s[1], D = s[2];
  const Tensor xc = x.data().contiguous(), shc = shift.data().contiguous(), scc = scale.data().contiguous();
  Tensor out = Tensor::empty(s, xc.dtype());
  if (xc.dtype() == DType::f32)
    modulate_fwd<float>(out.data<float>(), xc.data<float>(), shc.data<float>(), scc.data<float>(), B, Tn, D);
  else
    modulate_fwd<double>(out.data<double>(), xc.data<double>(), shc.data<double>(), scc.data<double>(), B, Tn, D);
  return ag::record("modulate", out, {x, shift, scale},
                    [xc, scc, B, Tn, D](const Tensor& grad, const std::vector<bool>& need) {
                      const Tensor g = grad.contiguous();
                      std::vector<Tensor> r(3);
                      if (need[0]) r[0] = Tensor::empty(xc.shape(), g.dtype());
                      if (need[1]) r[1] = Tensor::empty({B, D}, g.dtype());
                      if (need[2]) r[2] = Tensor::empty({B, D}, g.dtype());
                      if (g.dtype() == DType::f32)
                        modulate_bwd<float>(ptr<float>(r[0]), ptr<float>(r[1]), ptr<float>(r[2]), g.data<float>(),
                                            xc.data<float>(), scc.data<float>(), B, Tn, D);
                      else
                        modulate_bwd<double>(ptr<double>(r[0]), ptr<double>(r[1]), ptr<double>(r[2]),
                                             g.data<double>(), xc.data<double>(), scc.data<double>(), B, Tn, D);
                      return r;
                    });
}

// x (B,T,D), gate (B,D), y (B,T,D) -> (B,T,D)
ag::Variable gated_residual(const ag::Variable& x, const ag::Variable& gate, const ag::Variable& y) {
  const Shape s = check_btd("gated_residual", x.data(), gate.data(), Tensor(), y.data());
  const int64_t B = s[0], Tn = s[1], D = s[2];
  const Tensor xc = x.data().contiguous(), gc = gate.data().contiguous(), yc = y.data().contiguous();
  Tensor out = Tensor::empty(s, xc.dtype());
  if (xc.dtype() == DType::f32)
    gated_fwd<float>(out.data<float>(), xc.data<float>(), gc.data<float>(), yc.data<float>(), B, Tn, D);
  else
    gated_fwd<double>(out.data<double>(), xc.data<double>(), gc.data<double>(), yc.data<double>(), B, Tn, D);
  return ag::record("gated_residual", out, {x, gate, y},
                    [gc, yc, B, Tn, D](const Tensor& grad, const std::vector<bool>& need) {
                      const Tensor g = grad.contiguous();
                      std::vector<Tensor> r(3);
                      if (need[0]) r[0] = g;
                      if (need[1]) r[1] = Tensor::empty({B, D}, g.dtype());
                      if (need[2]) r[2] = Tensor::empty(yc.shape(), g.dtype());
                      if (g.dtype() == DType::f32)
                        gated_bwd<float>(ptr<float>(r[2]), ptr<float>(r[1]), g.data<float>(), gc.data<float>(),
                                         yc.data<float>(), B, Tn, D);
                      else
                        gated_bwd<double>(ptr<double>(r[2]), ptr<double>(r[1]), g.data<double>(), gc.data<double>(),
                                          yc.data<double>(), B, Tn, D);
                      return r;
                    });
}

AdaLN::AdaLN(int64_t cond_dim, int64_t dim, int64_t chunks, Generator& gen)
    : cond_dim_(cond_dim), dim_(dim), chunks_(chunks) {
  if (cond_dim < 1 || dim < 1 || chunks < 1)
    throw Error("AdaLN: cond_dim, dim and chunks must be >= 1, got " + std::to_string(cond_dim) + ", " +
                std::to_string(dim) + ", " + std::to_string(chunks));
  const double bound = 1.0 / std::sqrt((double)cond_dim);
  weight = register_parameter("weight", rand_uniform({chunks * dim, cond_dim}, gen, -bound, bound));
  bias = register_parameter("bias", rand_uniform({chunks * dim}, gen, -bound, bound));
}

void AdaLN::zero_init() {
  weight.data().zero_();
  bias.data().zero_();
}

// c (B, C): silu(c) W^T + b -> (B, n*D) -> n chunks (B, D)
std::vector<ag::Variable> AdaLN::forward(const ag::Variable& c) const {
  if (c.dim() != 2 || c.size(1) != cond_dim_)
    throw Error("AdaLN: c must be (B, " + std::to_string(cond_dim_) + "), got " + shape_str(c.shape()));
  ag::Variable h = linear(ag::silu(c), weight, bias);  // one GEMM, bias fused
  return ag::chunk(h, chunks_, 1);
}

}  // namespace t2m::nn
