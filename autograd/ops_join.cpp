// ops_join.cpp — forward/backward pairs of concat and stack; split/chunk as narrows.
#include "autograd/ops_join.h"

#include "autograd/ops_shape.h"
#include "tensor/ops.h"

namespace t2m::ag {

namespace {
std::vector<Tensor> datas(const std::vector<Variable>& ts) {
  std::vector<Tensor> d;
  d.reserve(ts.size());
  for (const auto& t : ts) d.push_back(t.data());
  return d;
}
}  // namespace

// ts[i]: [..., n_i, ...] at dim; out: [..., sum n_i, ...]; dts[i] = g.narrow(dim, offset_i, n_i)
Variable concat(const std::vector<Variable>& ts, int64_t dim) {
  Tensor out = t2m::concat(datas(ts), dim);
  int64_t d = wrap_dim(dim, out.dim(), "concat");
  std::vector<int64_t> sizes;
  for (const auto& t : ts) sizes.push_back(t.size(d));
  return record("concat", out, ts, [sizes, d](const Tensor& g, const std::vector<bool>& need) {
    std::vector<Tensor> grads(sizes.size());
    int64_t off = 0;
    for (size_t i = 0; i < sizes.size(); ++i) {
      if (need[i]) grads[i] = g.narrow(d, off, sizes[i]);
      off += sizes[i];
    }
    return grads;
  });
}

// ts[i]: S; out: S with a new dim of size n inserted at dim; dts[i] = g.select(dim, i)
Variable stack(const std::vector<Variable>& ts, int64_t dim) {
  Tensor out = t2m::stack(datas(ts), dim);
  int64_t d = wrap_dim(dim, out.dim(), "stack");
  return record("stack", out, ts, [d](const Tensor& g, const std::vector<bool>& need) {
    std::vector<Tensor> grads(need.size());
    for (size_t i = 0; i < need.size(); ++i)
      if (need[i]) grads[i] = g.select(d, (int64_t)i);
    return grads;
  });
}

namespace {
// Each tensor piece is a narrow of `a` along d; rebuild it as a differentiable narrow.
std::vector<Variable> narrows_like(const Variable& a, const std::vector<Tensor>& pieces, int64_t d) {
  std::vector<Variable> out;
  out.reserve(pieces.size());
  int64_t off = 0;
  for (const auto& p : pieces) {
    out.push_back(narrow(a, d, off, p.size(d)));
    off += p.size(d);
  }
  return out;
}
}  // namespace

std::vector<Variable> split(const Variable& a, const std::vector<int64_t>& sizes, int64_t dim) {
  std::vector<Tensor> pieces = t2m::split(a.data(), sizes, dim);  // validates sizes
  return narrows_like(a, pieces, wrap_dim(dim, a.dim(), "split"));
}

std::vector<Variable> chunk(const Variable& a, int64_t chunks, int64_t dim) {
  std::vector<Tensor> pieces = t2m::chunk(a.data(), chunks, dim);
  return narrows_like(a, pieces, wrap_dim(dim, a.dim(), "chunk"));
}

}  // namespace t2m::ag
