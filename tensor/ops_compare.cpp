// ops_compare.cpp — allclose / max_abs_diff: test helpers comparing two tensors elementwise in double.
#include <cmath>
#include <limits>

#include "tensor/kernels.h"
#include "tensor/ops.h"

namespace t2m {

// Both tensors converted to contiguous f64; shapes must match exactly.
static void as_f64_pair(const Tensor& a, const Tensor& b, const char* op, Tensor& da, Tensor& db) {
  detail::check_defined(a, op, "first");
  detail::check_defined(b, op, "second");
  if (a.shape() != b.shape())
    throw Error(std::string(op) + ": shape mismatch " + shape_str(a.shape()) + " vs " + shape_str(b.shape()));
  da = a.to(DType::f64).contiguous();
  db = b.to(DType::f64).contiguous();
}

// |a - b| <= atol + rtol * |b| everywhere; NaN anywhere fails, equal infinities pass.
bool allclose(const Tensor& a, const Tensor& b, double rtol, double atol) {
  Tensor da, db;
  as_f64_pair(a, b, "allclose", da, db);
  const double* x = da.data<double>();
  const double* y = db.data<double>();
  for (int64_t i = 0; i < da.numel(); ++i) {
    if (x[i] == y[i]) continue;
    if (!(std::abs(x[i] - y[i]) <= atol + rtol * std::abs(y[i]))) return false;
  }
  return true;
}

// max |a - b| (0 for empty tensors; NaN if any element pair involves NaN, equal infinities count as 0).
double max_abs_diff(const Tensor& a, const Tensor& b) {
  Tensor da, db;
  as_f64_pair(a, b, "max_abs_diff", da, db);
  const double* x = da.data<double>();
  const double* y = db.data<double>();
  double m = 0;
  for (int64_t i = 0; i < da.numel(); ++i) {
    if (x[i] == y[i]) continue;
    const double d = std::abs(x[i] - y[i]);
    if (d != d) return std::numeric_limits<double>::quiet_NaN();
    m = std::max(m, d);
  }
  return m;
}

}  // namespace t2m
