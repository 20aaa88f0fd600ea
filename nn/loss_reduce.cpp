// loss_reduce.cpp — weighted mean with validated non-negative weights; key-padding mask conversion.
#include "nn/loss_reduce.h"

#include <cmath>
#include <string>

#include "autograd/ops_elementwise.h"
#include "autograd/ops_reduce.h"
#include "tensor/ops.h"

namespace t2m::nn {

bool broadcasts_to(const Shape& from, const Shape& to) {
  if (from.size() > to.size()) return false;
  const size_t off = to.size() - from.size();
  for (size_t d = 0; d < from.size(); ++d)
    if (from[d] != 1 && from[d] != to[off + d]) return false;
  return true;
}

namespace {

// Checks weights against values' shape V; returns them in values' dtype and sets *total = sum(expand(w, V)).
Tensor checked_weights(const ag::Variable& values, const Tensor& weights, const char* op, double* total) {
  const Shape& V = values.shape();
  if (!broadcasts_to(weights.shape(), V))
    throw Error(std::string(op) + ": weights " + shape_str(weights.shape()) + " do not broadcast to values " +
                shape_str(V));
  const Tensor w64 = weights.to(DType::f64).contiguous();
  const double* pw = w64.data<double>();
  for (int64_t i = 0; i < w64.numel(); ++i)
    if (!std::isfinite(pw[i]) || pw[i] < 0.0)
      throw Error(std::string(op) + ": weights must be finite and >= 0, got " + std::to_string(pw[i]) +
                  " at flat index " + std::to_string(i) + " of " + shape_str(weights.shape()));
  *total = t2m::sum(w64.expand(V)).item();
  return weights.to(values.dtype());
}

}  // namespace

// values (V), weights (W broadcastable to V) -> scalar sum(w v)
ag::Variable weighted_sum(const ag::Variable& values, const Tensor& weights, const char* op) {
  if (!values.defined()) throw Error(std::string(op) + ": values are undefined");
  if (!weights.defined()) return ag::sum(values);
  double total = 0.0;
  const Tensor w = checked_weights(values, weights, op, &total);
  return ag::sum(ag::mul(values, ag::Variable(w)));
}

// values (V), weights (W broadcastable to V) -> scalar sum(w v) / sum(expand(w, V))
ag::Variable weighted_mean(const ag::Variable& values, const Tensor& weights, const char* op) {
  if (!values.defined()) throw Error(std::string(op) + ": values are undefined");
  if (!weights.defined()) return ag::mean(values);
  double total = 0.0;
  const Tensor w = checked_weights(values, weights, op, &total);
  ag::Variable num = ag::sum(ag::mul(values, ag::Variable(w)));
  return ag::div(num, total > 0.0 ? total : 1.0);  // all-zero weights: num is 0, so the result is 0
}

Tensor valid_mask(const Tensor& mask, const Shape& shape, DType dtype, const char* op, const char* what) {
  if (!mask.defined()) throw Error(std::string(op) + ": " + what + " is undefined");
  if (mask.shape() != shape)
    throw Error(std::string(op) + ": " + what + " must have shape " + shape_str(shape) + ", got " +
                shape_str(mask.shape()));
  const Tensor m64 = mask.to(DType::f64).contiguous();
  Tensor out = Tensor::empty(shape, DType::f64);
  const double* pm = m64.data<double>();
  double* po = out.data<double>();
  for (int64_t i = 0; i < m64.numel(); ++i) po[i] = pm[i] != 0.0 ? 1.0 : 0.0;
  return out.to(dtype);
}

}  // namespace t2m::nn
