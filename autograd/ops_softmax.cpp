// ops_softmax.cpp — forward/backward pairs of softmax and log_softmax along `dim`.
#include "autograd/ops_softmax.h"

#include "tensor/ops.h"

namespace t2m::ag {

namespace {
// a - amax(a, dim): the shift is exact in floating point for the largest element, so results near the maximum
// keep full precision even for large inputs (a - logsumexp(a) would lose the low bits of large values).
Tensor shifted(const Tensor& a, int64_t dim) { return t2m::sub(a, t2m::amax(a, {dim}, /*keepdim=*/true)); }
}  // namespace

// a: A; s = a - max(a); out = s - log(sum(exp(s), dim)); da = g - softmax(a) * sum(g, dim)
Variable log_softmax(const Variable& a, int64_t dim) {
  Tensor s = shifted(a.data(), dim);
  Tensor out = t2m::sub(s, t2m::log(t2m::sum(t2m::exp(s), {dim}, /*keepdim=*/true)));
  return record("log_softmax", out, {a}, [out, dim](const Tensor& g, const std::vector<bool>&) {
    Tensor y = t2m::exp(out);
    return std::vector<Tensor>{t2m::sub(g, t2m::mul(y, t2m::sum(g, {dim}, /*keepdim=*/true)))};
  });
}

// a: A; e = exp(a - max(a)); out = y = e / sum(e, dim); da = y * (g - sum(g * y, dim))
Variable softmax(const Variable& a, int64_t dim) {
  Tensor e = t2m::exp(shifted(a.data(), dim));
  Tensor y = t2m::div(e, t2m::sum(e, {dim}, /*keepdim=*/true));
  return record("softmax", y, {a}, [y, dim](const Tensor& g, const std::vector<bool>&) {
    Tensor gy = t2m::sum(t2m::mul(g, y), {dim}, /*keepdim=*/true);
    return std::vector<Tensor>{t2m::mul(y, t2m::sub(g, gy))};
  });
}

}  // namespace t2m::ag
