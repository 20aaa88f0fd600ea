// ops_shape.cpp — forward/backward pairs of the view ops, and the Variable member forms of them.
#include "autograd/ops_shape.h"

#include "tensor/ops.h"

namespace t2m::ag {

namespace {
using Grads = std::vector<Tensor>;
using Need = std::vector<bool>;

// Gradient of a strided sub-view: zeros of shape A with g written through the same view of them.
template <typename MakeView>
Tensor scatter_into_zeros(const Tensor& g, const Shape& A, MakeView make_view) {
  Tensor da = Tensor::zeros(A, g.dtype());
  Tensor part = make_view(da);
  part.copy_(g);
  return da;
}

// out = a with the same elements in a new shape; da = reshape(g, A)
Variable reshape_like(const char* op, const Variable& a, Tensor out) {
  Shape A = a.shape();
  return record(op, std::move(out), {a}, [A](const Tensor& g, const Need&) { return Grads{g.reshape(A)}; });
}
}  // namespace

Variable view(const Variable& a, const Shape& shape) { return reshape_like("view", a, a.data().view(shape)); }
Variable reshape(const Variable& a, const Shape& shape) { return reshape_like("reshape", a, a.data().reshape(shape)); }
Variable squeeze(const Variable& a, int64_t dim) { return reshape_like("squeeze", a, a.data().squeeze(dim)); }
Variable unsqueeze(const Variable& a, int64_t dim) { return reshape_like("unsqueeze", a, a.data().unsqueeze(dim)); }
Variable flatten(const Variable& a, int64_t start_dim, int64_t end_dim) {
  return reshape_like("flatten", a, a.data().flatten(start_dim, end_dim));
}

// out = a with dims d0, d1 swapped; da = transpose(g, d0, d1)
Variable transpose(const Variable& a, int64_t d0, int64_t d1) {
  return record("transpose", a.data().transpose(d0, d1), {a},
                [d0, d1](const Tensor& g, const Need&) { return Grads{g.transpose(d0, d1)}; });
}

// out dim i = a dim dims[i]; da = permute(g, inverse(dims))
Variable permute(const Variable& a, const std::vector<int64_t>& dims) {
  Tensor out = a.data().permute(dims);  // validates dims
  std::vector<int64_t> inv(dims.size());
  for (size_t i = 0; i < dims.size(); ++i) inv[wrap_dim(dims[i], (int64_t)dims.size(), "permute")] = (int64_t)i;
  return record("permute", out, {a}, [inv](const Tensor& g, const Need&) { return Grads{g.permute(inv)}; });
}

// out = a[..., start:end:step, ...]; da = zeros(A) with g written into that slice
Variable slice(const Variable& a, int64_t dim, int64_t start, int64_t end, int64_t step) {
  Shape A = a.shape();
  return record("slice", a.data().slice(dim, start, end, step), {a},
                [A, dim, start, end, step](const Tensor& g, const Need&) {
                  return Grads{scatter_into_zeros(g, A, [&](const Tensor& z) { return z.slice(dim, start, end, step); })};
                });
}

// out = a[..., index, ...] (dim removed); da = zeros(A) with g written at index
Variable select(const Variable& a, int64_t dim, int64_t index) {
  Shape A = a.shape();
  return record("select", a.data().select(dim, index), {a}, [A, dim, index](const Tensor& g, const Need&) {
    return Grads{scatter_into_zeros(g, A, [&](const Tensor& z) { return z.select(dim, index); })};
  });
}

// out = a[..., start:start+length, ...]; da = zeros(A) with g written there
Variable narrow(const Variable& a, int64_t dim, int64_t start, int64_t length) {
  Shape A = a.shape();
  return record("narrow", a.data().narrow(dim, start, length), {a}, [A, dim, start, length](const Tensor& g, const Need&) {
    return Grads{scatter_into_zeros(g, A, [&](const Tensor& z) { return z.narrow(dim, start, length); })};
  });
}

// out = a broadcast to shape; da = g summed back to A (reduce_grad_to)
Variable expand(const Variable& a, const Shape& shape) {
  Shape A = a.shape();
  return record("expand", a.data().expand(shape), {a},
                [A](const Tensor& g, const Need&) { return Grads{reduce_grad_to(g, A)}; });
}

// out = contiguous copy of a (or a itself); da = g
Variable contiguous(const Variable& a) {
  if (a.data().is_contiguous()) return a;
  return record("contiguous", a.data().contiguous(), {a}, [](const Tensor& g, const Need&) { return Grads{g}; });
}

Variable Variable::view(const Shape& shape) const { return ag::view(*this, shape); }
Variable Variable::reshape(const Shape& shape) const { return ag::reshape(*this, shape); }
Variable Variable::transpose(int64_t d0, int64_t d1) const { return ag::transpose(*this, d0, d1); }
Variable Variable::permute(const std::vector<int64_t>& dims) const { return ag::permute(*this, dims); }
Variable Variable::slice(int64_t dim, int64_t start, int64_t end, int64_t step) const {
  return ag::slice(*this, dim, start, end, step);
}
Variable Variable::select(int64_t dim, int64_t index) const { return ag::select(*this, dim, index); }
Variable Variable::narrow(int64_t dim, int64_t start, int64_t length) const {
  return ag::narrow(*this, dim, start, length);
}
Variable Variable::expand(const Shape& shape) const { return ag::expand(*this, shape); }
Variable Variable::squeeze(int64_t dim) const { return ag::squeeze(*this, dim); }
Variable Variable::unsqueeze(int64_t dim) const { return ag::unsqueeze(*this, dim); }
Variable Variable::flatten(int64_t start_dim, int64_t end_dim) const { return ag::flatten(*this, start_dim, end_dim); }
Variable Variable::contiguous() const { return ag::contiguous(*this); }

}  // namespace t2m::ag
