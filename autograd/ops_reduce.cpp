// ops_reduce.cpp — forward/backward pairs of the reductions. In each backward, g has the reduced shape (with or
// without keepdim); it is reshaped to the keepdim shape K and broadcast back to the input shape A.
#include "autograd/ops_reduce.h"

#include "autograd/ops_index.h"
#include "tensor/ops.h"

namespace t2m::ag {

namespace {
using Grads = std::vector<Tensor>;
using Need = std::vector<bool>;
}  // namespace

Shape reduced_shape_keepdim(const Shape& a_shape, const std::vector<int64_t>& dims, const char* op) {
  int64_t nd = (int64_t)a_shape.size();
  Shape k = a_shape;
  if (dims.empty()) {
    for (auto& s : k) s = 1;
    return k;
  }
  for (int64_t d : dims) k[wrap_dim(d, nd, op)] = 1;
  return k;
}

// out = sum over dims of a; da[A] = expand(reshape(g, K), A)
Variable sum(const Variable& a, const std::vector<int64_t>& dims, bool keepdim) {
  Shape A = a.shape();
  Shape K = reduced_shape_keepdim(A, dims, "sum");
  return record("sum", t2m::sum(a.data(), dims, keepdim), {a}, [A, K](const Tensor& g, const Need&) {
    return Grads{g.reshape(K).expand(A)};
  });
}

// out = sum / n with n = number of reduced elements; da = expand(reshape(g, K), A) / n
Variable mean(const Variable& a, const std::vector<int64_t>& dims, bool keepdim) {
  Shape A = a.shape();
  Shape K = reduced_shape_keepdim(A, dims, "mean");
  int64_t n = shape_numel(K) == 0 ? 0 : shape_numel(A) / shape_numel(K);
  double scale = n == 0 ? 0.0 : 1.0 / (double)n;
  return record("mean", t2m::mean(a.data(), dims, keepdim), {a}, [A, K, scale](const Tensor& g, const Need&) {
    return Grads{t2m::mul(g.reshape(K), scale).expand(A)};
  });
}

// a: A (broadcastable from S), out: S. da = expand(g, A)
Variable sum_to(const Variable& a, const Shape& shape) {
  Shape A = a.shape();
  return record("sum_to", t2m::sum_to(a.data(), shape), {a},
                [A](const Tensor& g, const Need&) { return Grads{g.expand(A)}; });
}

namespace {

// Shared by amax/amin: mask = (a == out) over A; da = g * mask / count(mask) (ties split evenly).
Variable extreme(const char* op, const Variable& a, const std::vector<int64_t>& dims, bool keepdim, bool is_max) {
  Tensor ta = a.data();
  Shape K = reduced_shape_keepdim(ta.shape(), dims, op);
  Tensor out = is_max ? t2m::amax(ta, dims, keepdim) : t2m::amin(ta, dims, keepdim);
  std::vector<int64_t> rdims = dims;
  if (rdims.empty())
    for (int64_t d = 0; d < ta.dim(); ++d) rdims.push_back(d);
  return record(op, out, {a}, [ta, out, K, rdims](const Tensor& g, const Need&) {
    Tensor mask = t2m::eq(ta, out.reshape(K));                  // A
    Tensor count = t2m::sum(mask, rdims, /*keepdim=*/true);     // K
    return Grads{t2m::mul(mask, t2m::div(g.reshape(K), count))};
  });
}

}  // namespace

Variable amax(const Variable& a, const std::vector<int64_t>& dims, bool keepdim) {
  return extreme("amax", a, dims, keepdim, true);
}
Variable amin(const Variable& a, const std::vector<int64_t>& dims, bool keepdim) {
  return extreme("amin", a, dims, keepdim, false);
}

// out = log sum exp(a) over dim; da = g * exp(a - out)  (the softmax of a along dim)
Variable logsumexp(const Variable& a, int64_t dim, bool keepdim) {
  Tensor ta = a.data();
  Shape K = reduced_shape_keepdim(ta.shape(), {dim}, "logsumexp");
  Tensor out = t2m::logsumexp(ta, dim, keepdim);
  return record("logsumexp", out, {a}, [ta, out, K](const Tensor& g, const Need&) {
    return Grads{t2m::mul(g.reshape(K), t2m::exp(t2m::sub(ta, out.reshape(K))))};
  });
}

// values = gather(a, dim, argmax) — the gradient goes to the first maximum through gather's backward.
MaxResult max(const Variable& a, int64_t dim, bool keepdim) {
  t2m::MaxResult m = t2m::max(a.data(), dim, /*keepdim=*/true);
  Variable values = gather(a, dim, m.indices);
  if (!keepdim) {
    int64_t d = wrap_dim(dim, a.dim(), "max");
    values = values.squeeze(d);
    m.indices = m.indices.squeeze(d);
  }
  return {values, m.indices};
}

Tensor argmax(const Variable& a, int64_t dim, bool keepdim) { return t2m::argmax(a.data(), dim, keepdim); }

}  // namespace t2m::ag
