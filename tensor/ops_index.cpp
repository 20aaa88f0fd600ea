// ops_index.cpp — index_select, gather, scatter_add, index_add, masked_fill.
//
// Every index is validated before any work (kernels never throw inside OpenMP regions): the first index outside
// [0, size) throws Error naming the op, the index, the dim and its size. Negative indices are rejected.
// Scatters (scatter_add, index_add) run in a fixed order, so duplicate indices accumulate deterministically.
#include <cstring>

#include "tensor/kernels.h"
#include "tensor/ops.h"
#include "tensor/strided_iter.h"

namespace t2m {
namespace {

using detail::strided_for_each;
using Off3 = std::array<int64_t, 3>;

// Contiguous int64 copy of index with every value checked against [0, size).
Tensor checked_index(const Tensor& index, int64_t size, int64_t dim, const char* op) {
  detail::check_index(index, op);
  Tensor c = index.contiguous();
  const int64_t* p = c.data<int64_t>();
  for (int64_t i = 0; i < c.numel(); ++i)
    if (p[i] < 0 || p[i] >= size)
      throw Error(std::string(op) + ": index " + std::to_string(p[i]) + " out of range for dim " +
                  std::to_string(dim) + " of size " + std::to_string(size));
  return c;
}

// Product of shape[lo, hi).
int64_t prod(const Shape& s, int64_t lo, int64_t hi) {
  int64_t n = 1;
  for (int64_t i = lo; i < hi; ++i) n *= s[i];
  return n;
}

}  // namespace

// out[o, i, r] = a[o, index[i], r] with a viewed as [outer, n, inner] (made contiguous first).
Tensor index_select(const Tensor& a, int64_t dim, const Tensor& index) {
  detail::check_defined(a, "index_select");
  const int64_t d = wrap_dim(dim, a.dim(), "index_select");
  if (index.defined() && index.dim() != 1)
    throw Error("index_select: index must be 1-d, got " + shape_str(index.shape()));
  const Tensor idx = checked_index(index, a.shape()[d], d, "index_select");
  const Tensor ac = a.contiguous();
  Shape os = a.shape();
  os[d] = idx.numel();
  Tensor out = Tensor::empty(os, a.dtype());
  const int64_t outer = prod(a.shape(), 0, d), n = a.shape()[d], inner = prod(a.shape(), d + 1, a.dim());
  const int64_t ni = idx.numel();
  const size_t row = (size_t)inner * dtype_size(a.dtype());
  const char* src = static_cast<const char*>(ac.storage()->data) + ac.offset() * dtype_size(a.dtype());
  char* dst = static_cast<char*>(out.storage()->data);
  const int64_t* ip = idx.data<int64_t>();
  const int nt = detail::threads_for(outer * ni * inner);
#pragma omp parallel for if (nt > 1) num_threads(nt) schedule(static)
  for (int64_t oi = 0; oi < outer * ni; ++oi) {
    const int64_t o = oi / ni, i = oi % ni;
    std::memcpy(dst + (size_t)oi * row, src + ((size_t)(o * n + ip[i])) * row, row);
  }
  return out;
}

// out[p] = a[p with p[dim] replaced by index[p]] over the index shape (torch.gather).
Tensor gather(const Tensor& a, int64_t dim, const Tensor& index) {
  detail::check_defined(a, "gather");
  detail::check_index(index, "gather");
  const int64_t d = wrap_dim(dim, a.dim(), "gather");
  bool ok = index.dim() == a.dim();
  for (int64_t k = 0; ok && k < a.dim(); ++k) ok = k == d || index.shape()[k] <= a.shape()[k];
  if (!ok)
    throw Error("gather: index " + shape_str(index.shape()) + " does not fit input " + shape_str(a.shape()) +
                " (same ndim, sizes <= input outside dim " + std::to_string(d) + ")");
  const Tensor idx = checked_index(index, a.shape()[d], d, "gather");
  Tensor out = Tensor::empty(index.shape(), a.dtype());
  Shape as = a.strides();
  const int64_t sd = as[d];
  as[d] = 0;
  const std::array<Shape, 3> st{out.strides(), idx.strides(), as};
  detail::dispatch_all(a.dtype(), [&](auto z) {
    using T = decltype(z);
    T* po = out.data<T>();
    const int64_t* pi = idx.data<int64_t>();
    const T* pa = a.data<T>();
    strided_for_each<3>(index.shape(), st, [&](const Off3& off, const Off3& s, int64_t n) {
      for (int64_t i = 0; i < n; ++i) po[off[0] + i * s[0]] = pa[off[2] + i * s[2] + pi[off[1] + i * s[1]] * sd];
    });
  });
  return out;
}

// out = a.clone(); out[p with p[dim] = index[p]] += src[p] over the index shape (torch.scatter_add).
Tensor scatter_add(const Tensor& a, int64_t dim, const Tensor& index, const Tensor& src) {
  detail::check_float_pair(a, src, "scatter_add");
  detail::check_index(index, "scatter_add");
  const int64_t d = wrap_dim(dim, a.dim(), "scatter_add");
  bool ok = index.dim() == a.dim() && src.dim() == a.dim();
  for (int64_t k = 0; ok && k < a.dim(); ++k)
    ok = index.shape()[k] <= src.shape()[k] && (k == d || index.shape()[k] <= a.shape()[k]);
  if (!ok)
    throw Error("scatter_add: index " + shape_str(index.shape()) + " does not fit src " + shape_str(src.shape()) +
                " and input " + shape_str(a.shape()) + " (dim " + std::to_string(d) + ")");
  const Tensor idx = checked_index(index, a.shape()[d], d, "scatter_add");
  Tensor out = a.clone();
  Shape os = out.strides();
  const int64_t sd = os[d];
  os[d] = 0;
  const std::array<Shape, 3> st{os, idx.strides(), src.strides()};
  detail::dispatch_float(a.dtype(), "scatter_add", [&](auto z) {
    using T = decltype(z);
    T* po = out.data<T>();
    const int64_t* pi = idx.data<int64_t>();
    const T* ps = src.data<T>();
    strided_for_each<3>(
        index.shape(), st,
        [&](const Off3& off, const Off3& s, int64_t n) {
          for (int64_t i = 0; i < n; ++i) po[off[0] + i * s[0] + pi[off[1] + i * s[1]] * sd] += ps[off[2] + i * s[2]];
        },
        /*parallel=*/false);
  });
  return out;
}

// out = a.clone(); out[o, index[i], r] += src[o, i, r] (a viewed as [outer, n, inner]).
Tensor index_add(const Tensor& a, int64_t dim, const Tensor& index, const Tensor& src) {
  detail::check_float_pair(a, src, "index_add");
  const int64_t d = wrap_dim(dim, a.dim(), "index_add");
  detail::check_index(index, "index_add");
  if (index.dim() != 1) throw Error("index_add: index must be 1-d, got " + shape_str(index.shape()));
  Shape want = a.shape();
  want[d] = index.numel();
  if (src.shape() != want)
    throw Error("index_add: src " + shape_str(src.shape()) + " must be " + shape_str(want) + " for input " +
                shape_str(a.shape()) + " and " + std::to_string(index.numel()) + " indices in dim " +
                std::to_string(d));
  const Tensor idx = checked_index(index, a.shape()[d], d, "index_add");
  Tensor out = a.clone();
  const Tensor sc = src.contiguous();
  const int64_t outer = prod(a.shape(), 0, d), n = a.shape()[d], inner = prod(a.shape(), d + 1, a.dim());
  const int64_t ni = idx.numel();
  detail::dispatch_float(a.dtype(), "index_add", [&](auto z) {
    using T = decltype(z);
    T* po = out.data<T>();
    const T* ps = sc.data<T>();
    const int64_t* ip = idx.data<int64_t>();
    // Each outer slice is independent: threads split outer; inside, indices apply in order.
    const int nt = outer > 1 ? detail::threads_for(outer * ni * inner) : 1;
#pragma omp parallel for if (nt > 1) num_threads(nt) schedule(static)
    for (int64_t o = 0; o < outer; ++o)
      for (int64_t i = 0; i < ni; ++i) {
        T* dst = po + (o * n + ip[i]) * inner;
        const T* s = ps + (o * ni + i) * inner;
        for (int64_t r = 0; r < inner; ++r) dst[r] += s[r];
      }
  });
  return out;
}

// where(mask != 0, value, a) with mask broadcast to a's shape (mask may be f32, f64 or i64).
Tensor masked_fill(const Tensor& a, const Tensor& mask, double value) {
  detail::check_defined(a, "masked_fill");
  detail::check_defined(mask, "masked_fill", "mask");
  if (broadcast_shapes(a.shape(), mask.shape(), "masked_fill") != a.shape())
    throw Error("masked_fill: mask " + shape_str(mask.shape()) + " does not broadcast to input " +
                shape_str(a.shape()));
  Tensor out = Tensor::empty(a.shape(), a.dtype());
  const std::array<Shape, 3> st{out.strides(), a.strides(), detail::broadcast_strides(mask, a.shape(), "masked_fill")};
  detail::dispatch_float(a.dtype(), "masked_fill", [&](auto z) {
    using T = decltype(z);
    T* po = out.data<T>();
    const T* pa = a.data<T>();
    const T v = (T)value;
    detail::dispatch_all(mask.dtype(), [&](auto mz) {
      using M = decltype(mz);
      const M* pm = mask.data<M>();
      strided_for_each<3>(a.shape(), st, [&](const Off3& off, const Off3& s, int64_t n) {
        for (int64_t i = 0; i < n; ++i)
          po[off[0] + i * s[0]] = pm[off[2] + i * s[2]] != M(0) ? v : pa[off[1] + i * s[1]];
      });
    });
  });
  return out;
}

}  // namespace t2m
