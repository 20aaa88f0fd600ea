// fb_loss.cpp — the fused off-diagonal/diagonal loss (one pass forward computing diff and both terms, one pass
// backward), and the FB TD / orthonormality losses and the ensemble pessimism built on it.
#include "models/bfm/fb_loss.h"

#include <string>
#include <vector>

#include "autograd/node.h"
#include "autograd/ops_elementwise.h"
#include "autograd/ops_linalg.h"
#include "autograd/ops_reduce.h"
#include "autograd/ops_unary.h"
#include "tensor/ops.h"
#include "tensor/parallel.h"

namespace t2m::bfm {

namespace {

// Forward over rows r = (e, i) of X [E*B, B]: diff = X - gamma_i T_i (T, gamma may be null), written to `diff`;
// off[r] = sum_{j != i} diff^2, dg[r] = diff_ii (double partials, summed by the caller in row order).
template <typename T>
void odl_forward(T* diff, double* off, double* dg, const T* X, const T* tgt, const T* gamma, int64_t E, int64_t B) {
  const int64_t rows = E * B;
  const int nt = rows * B < kParallelGrain ? 1 : get_num_threads();
#pragma omp parallel for schedule(static) num_threads(nt)
  for (int64_t r = 0; r < rows; ++r) {
    const int64_t i = r % B;
    const T* x = X + r * B;
    T* df = diff + r * B;
    const T gi = gamma ? gamma[i] : (T)0;
    if (tgt && gi != (T)0) {
      const T* t = tgt + i * B;
      for (int64_t j = 0; j < B; ++j) df[j] = x[j] - gi * t[j];
    } else {
      for (int64_t j = 0; j < B; ++j) df[j] = x[j];
    }
    double s = 0;  // in vector lanes (one fixed order per build): a single serial chain bound a 1024-row step
#pragma omp simd reduction(+ : s)
    for (int64_t j = 0; j < B; ++j) s += (double)df[j] * df[j];
    dg[r] = df[i];
    off[r] = s - (double)df[i] * df[i];
  }
}

// dX_eij = g * (diff_eij / (B (B-1))) off the diagonal, g * (-1 / B) on it. Overwrites `diff` in place.
template <typename T>
void odl_backward(T* dx, const T* diff, T g, int64_t E, int64_t B) {
  const int64_t rows = E * B;
  const T a = g / (T)((double)B * (B - 1)), c = -g / (T)B;
  const int nt = rows * B < kParallelGrain ? 1 : get_num_threads();
#pragma omp parallel for schedule(static) num_threads(nt)
  for (int64_t r = 0; r < rows; ++r) {
    const int64_t i = r % B;
    const T* df = diff + r * B;
    T* d = dx + r * B;
    for (int64_t j = 0; j < B; ++j) d[j] = a * df[j];
    d[i] = c;
  }
}

void check_aux(const char* what, const Tensor& t, const Shape& want, DType dt) {
  if (!t.defined()) return;
  if (t.shape() != want || t.dtype() != dt)
    throw Error(std::string("offdiag_diag_loss: ") + what + " must be " + shape_str(want) + " " + dtype_name(dt) +
                ", got " + shape_str(t.shape()) + " " + dtype_name(t.dtype()));
}

}  // namespace

// X [E, B, B] -> scalar;  saved: diff [E, B, B]
ag::Variable offdiag_diag_loss(const ag::Variable& X, const Tensor& target, const Tensor& gamma,
                               FbLossParts* parts) {
  if (X.dim() != 3 || X.size(1) != X.size(2))
    throw Error("offdiag_diag_loss: X must be [E, B, B], got " + shape_str(X.shape()));
  const DType dt = X.dtype();
  if (dt != DType::f32 && dt != DType::f64) throw Error("offdiag_diag_loss: X must be f32 or f64");
  const int64_t E = X.size(0), B = X.size(1);
  if (B < 2) throw Error("offdiag_diag_loss: batch must be >= 2, got " + shape_str(X.shape()));
  check_aux("target", target, {B, B}, dt);
  check_aux("gamma", gamma, {B}, dt);
  const Tensor xc = X.data().contiguous();
  const Tensor tc = target.defined() ? target.contiguous() : Tensor();
  const Tensor gc = gamma.defined() ? gamma.contiguous() : Tensor();
  Tensor diff = Tensor::empty({E, B, B}, dt);
  std::vector<double> off(E * B), dg(E * B);
  if (dt == DType::f32)
    odl_forward<float>(diff.data<float>(), off.data(), dg.data(), xc.data<float>(),
                       tc.defined() ? tc.data<float>() : nullptr, gc.defined() ? gc.data<float>() : nullptr, E, B);
  else
    odl_forward<double>(diff.data<double>(), off.data(), dg.data(), xc.data<double>(),
                        tc.defined() ? tc.data<double>() : nullptr, gc.defined() ? gc.data<double>() : nullptr, E, B);
  double so = 0, sd = 0;
  for (int64_t r = 0; r < E * B; ++r) {
    so += off[r];
    sd += dg[r];
  }
  const double offdiag = 0.5 * so / ((double)B * (B - 1)), diag = -sd / (double)B;
  if (parts) *parts = {offdiag, diag};
  const Tensor out = Tensor::scalar(offdiag + diag, dt);
  if (!ag::any_requires_grad({X})) return ag::Variable(out);
  return ag::record("offdiag_diag_loss", out, {X},
                    [diff, E, B](const Tensor& g, const std::vector<bool>& need) mutable {
                      std::vector<Tensor> res(1);
                      if (!need[0]) return res;
                      Tensor dx = Tensor::empty({E, B, B}, diff.dtype());
                      if (diff.dtype() == DType::f32)
                        odl_backward<float>(dx.data<float>(), diff.data<float>(), (float)g.item(), E, B);
                      else
                        odl_backward<double>(dx.data<double>(), diff.data<double>(), g.item(), E, B);
                      res[0] = dx;
                      return res;
                    });
}

// F [E, B, d], Bv [B, d] -> M = F Bv^T [E, B, B] -> scalar
ag::Variable fb_td_loss(const ag::Variable& F, const ag::Variable& Bv, const Tensor& target_M, const Tensor& gamma,
                        FbLossParts* parts) {
  if (F.dim() != 3 || Bv.dim() != 2 || F.size(1) != Bv.size(0) || F.size(2) != Bv.size(1))
    throw Error("fb_td_loss: F must be [E, B, d] and Bv [B, d], got " + shape_str(F.shape()) + " and " +
                shape_str(Bv.shape()));
  return offdiag_diag_loss(ag::matmul_t(F, false, Bv, true), target_M, gamma, parts);
}

// Bv [B, d] -> C = Bv Bv^T [1, B, B] -> scalar
ag::Variable ortho_loss(const ag::Variable& Bv, FbLossParts* parts) {
  if (Bv.dim() != 2) throw Error("ortho_loss: Bv must be [B, d], got " + shape_str(Bv.shape()));
  return offdiag_diag_loss(ag::matmul_t(Bv, false, Bv, true).unsqueeze(0), Tensor(), Tensor(), parts);
}

// x [E, ...] -> [...]
ag::Variable pessimistic(const ag::Variable& x, double p) {
  if (x.dim() < 1 || x.size(0) < 1) throw Error("pessimistic: x must be [E >= 1, ...], got " + shape_str(x.shape()));
  const int64_t E = x.size(0);
  ag::Variable m = ag::mean(x, {0});
  if (E == 1 || p == 0) return m;
  ag::Variable unc;
  for (int64_t e = 0; e < E; ++e)
    for (int64_t f = e + 1; f < E; ++f) {
      ag::Variable a = ag::abs(x.select(0, e) - x.select(0, f));
      unc = unc.defined() ? unc + a : a;
    }
  const double pairs = (double)E * (E - 1) / 2;
  return m - unc * (p / (2 * pairs));
}

// Ft [E, B, d], Bt [B, d] -> [B, B]
Tensor pessimistic_target_M(const Tensor& Ft, const Tensor& Bt, double p) {
  if (Ft.dim() != 3 || Bt.dim() != 2 || Ft.size(2) != Bt.size(1))
    throw Error("pessimistic_target_M: Ft must be [E, B, d] and Bt [B, d], got " + shape_str(Ft.shape()) + " and " +
                shape_str(Bt.shape()));
  return pessimistic(ag::Variable(matmul_t(Ft, false, Bt, true)), p).data();
}

}  // namespace t2m::bfm
