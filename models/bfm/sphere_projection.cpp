// sphere_projection.cpp — row-wise r u / max(|u|, eps): one pass forward (norm, scale), one pass backward.
#include "models/bfm/sphere_projection.h"

#include <cmath>
#include <string>

#include "autograd/node.h"
#include "tensor/parallel.h"

namespace t2m::bfm {

namespace {

void check(const Tensor& u, double radius) {
  if (u.dim() < 1) throw Error("sphere_project: input must have at least 1 dim, got " + shape_str(u.shape()));
  if (u.dtype() != DType::f32 && u.dtype() != DType::f64)
    throw Error(std::string("sphere_project: input must be f32 or f64, got ") + dtype_name(u.dtype()));
  if (!(radius > 0)) throw Error("sphere_project: radius must be > 0, got " + std::to_string(radius));
}

// u, y [rows, d]; inv_n [rows] = 1 / max(|u_row|, eps) (saved for backward). Accumulates the norm in double.
template <typename T>
void project_forward(T* y, T* inv_n, const T* u, int64_t rows, int64_t d, double r, double eps) {
  const int nt = rows * d < kParallelGrain ? 1 : get_num_threads();
#pragma omp parallel for schedule(static) num_threads(nt)
  for (int64_t i = 0; i < rows; ++i) {
    const T* ui = u + i * d;
    double ss = 0;
    for (int64_t k = 0; k < d; ++k) ss += (double)ui[k] * ui[k];
    const double n = std::max(std::sqrt(ss), eps);
    inv_n[i] = (T)(1.0 / n);
    const T s = (T)(r / n);
    for (int64_t k = 0; k < d; ++k) y[i * d + k] = ui[k] * s;
  }
}

// du = r inv_n (g - (g . yh) yh), yh = u inv_n, when |u| > eps; else r g / eps.
template <typename T>
void project_backward(T* du, const T* g, const T* u, const T* inv_n, int64_t rows, int64_t d, double r,
                      double eps) {
  const int nt = rows * d < kParallelGrain ? 1 : get_num_threads();
#pragma omp parallel for schedule(static) num_threads(nt)
  for (int64_t i = 0; i < rows; ++i) {
    const T* ui = u + i * d;
    const T* gi = g + i * d;
    const double in = inv_n[i];
    double gy = 0, ss = 0;
    for (int64_t k = 0; k < d; ++k) {
      gy += (double)gi[k] * ui[k];
      ss += (double)ui[k] * ui[k];
    }
    const bool clamped = std::sqrt(ss) <= eps;
    const T a = (T)(r * in), b = clamped ? (T)0 : (T)(r * in * in * in * gy);
    for (int64_t k = 0; k < d; ++k) du[i * d + k] = a * gi[k] - b * ui[k];
  }
}

}  // namespace

Tensor project_rows(const Tensor& u, double radius, double eps) {
  check(u, radius);
  const Tensor uc = u.contiguous();
  const int64_t d = uc.size(-1), rows = d == 0 ? 0 : uc.numel() / d;
  Tensor y = Tensor::empty(uc.shape(), uc.dtype());
  Tensor inv = Tensor::empty({rows}, uc.dtype());
  if (uc.dtype() == DType::f32)
    project_forward<float>(y.data<float>(), inv.data<float>(), uc.data<float>(), rows, d, radius, eps);
  else
    project_forward<double>(y.data<double>(), inv.data<double>(), uc.data<double>(), rows, d, radius, eps);
  return y;
}

// u [..., d] -> y [..., d];  saved: u (contiguous), inv_n [rows]
ag::Variable sphere_project(const ag::Variable& u, double radius, double eps) {
  check(u.data(), radius);
  const Tensor uc = u.data().contiguous();
  const int64_t d = uc.size(-1), rows = d == 0 ? 0 : uc.numel() / d;
  Tensor y = Tensor::empty(uc.shape(), uc.dtype());
  Tensor inv = Tensor::empty({rows}, uc.dtype());
  const bool f32 = uc.dtype() == DType::f32;
  if (f32)
    project_forward<float>(y.data<float>(), inv.data<float>(), uc.data<float>(), rows, d, radius, eps);
  else
    project_forward<double>(y.data<double>(), inv.data<double>(), uc.data<double>(), rows, d, radius, eps);
  if (!ag::any_requires_grad({u})) return ag::Variable(y);
  return ag::record("sphere_project", y, {u},
                    [uc, inv, rows, d, radius, eps, f32](const Tensor& g, const std::vector<bool>& need) {
                      std::vector<Tensor> out(1);
                      if (!need[0]) return out;
                      const Tensor gc = g.contiguous();
                      Tensor du = Tensor::empty(uc.shape(), uc.dtype());
                      if (f32)
                        project_backward<float>(du.data<float>(), gc.data<float>(), uc.data<float>(),
                                                inv.data<float>(), rows, d, radius, eps);
                      else
                        project_backward<double>(du.data<double>(), gc.data<double>(), uc.data<double>(),
                                                 inv.data<double>(), rows, d, radius, eps);
                      out[0] = du;
                      return out;
                    });
}

}  // namespace t2m::bfm
