// ops_index.cpp — forward/backward pairs of index_select and gather.
#include "autograd/ops_index.h"

#include "tensor/ops.h"

namespace t2m::ag {

// a: A, index: [L], out: A with A[dim] -> L. da = index_add(zeros(A), dim, index, g)
Variable index_select(const Variable& a, int64_t dim, const Tensor& index) {
  Shape A = a.shape();
  return record("index_select", t2m::index_select(a.data(), dim, index), {a},
                [A, dim, index](const Tensor& g, const std::vector<bool>&) {
                  return std::vector<Tensor>{t2m::index_add(Tensor::zeros(A, g.dtype()), dim, index, g)};
                });
}

// a: A, index: I (same ndim), out: I. da = scatter_add(zeros(A), dim, index, g)
Variable gather(const Variable& a, int64_t dim, const Tensor& index) {
  Shape A = a.shape();
  return record("gather", t2m::gather(a.data(), dim, index), {a}, [A, dim, index](const Tensor& g, const std::vector<bool>&) {
    return std::vector<Tensor>{t2m::scatter_add(Tensor::zeros(A, g.dtype()), dim, index, g)};
  });
}

// a: A, index/src: I, out: A. da = g, dsrc = gather(g, dim, index)
Variable scatter_add(const Variable& a, int64_t dim, const Tensor& index, const Variable& src) {
  return record("scatter_add", t2m::scatter_add(a.data(), dim, index, src.data()), {a, src},
                [dim, index](const Tensor& g, const std::vector<bool>& need) {
                  return std::vector<Tensor>{need[0] ? g : Tensor(), need[1] ? t2m::gather(g, dim, index) : Tensor()};
                });
}

// a: A, index: [L], src: A with A[dim] -> L, out: A. da = g, dsrc = index_select(g, dim, index)
Variable index_add(const Variable& a, int64_t dim, const Tensor& index, const Variable& src) {
  return record("index_add", t2m::index_add(a.data(), dim, index, src.data()), {a, src},
                [dim, index](const Tensor& g, const std::vector<bool>& need) {
                  return std::vector<Tensor>{need[0] ? g : Tensor(),
                                             need[1] ? t2m::index_select(g, dim, index) : Tensor()};
                });
}

}  // namespace t2m::ag
