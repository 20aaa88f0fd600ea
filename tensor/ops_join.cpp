// ops_join.cpp — concat / stack (copies into a fresh tensor), split / chunk (views).
#include <algorithm>

#include "tensor/kernels.h"
#include "tensor/ops.h"

namespace t2m {

namespace {
std::string shapes_str(const std::vector<Tensor>& ts) {
  std::string r;
  for (size_t i = 0; i < ts.size(); ++i) r += (i ? ", " : "") + shape_str(ts[i].shape());
  return r;
}
}  // namespace

Tensor concat(const std::vector<Tensor>& ts, int64_t dim) {
  if (ts.empty()) throw Error("concat: empty list of tensors");
  for (const Tensor& t : ts) detail::check_defined(t, "concat");
  const Tensor& t0 = ts[0];
  const int64_t d = wrap_dim(dim, t0.dim(), "concat");
  Shape out = t0.shape();
  out[d] = 0;
  for (const Tensor& t : ts) {
    if (t.dtype() != t0.dtype())
      throw Error(std::string("concat: dtype mismatch ") + dtype_name(t0.dtype()) + " vs " + dtype_name(t.dtype()) +
                  " (shapes " + shapes_str(ts) + ")");
    bool ok = t.dim() == t0.dim();
    for (int64_t k = 0; ok && k < t0.dim(); ++k) ok = k == d || t.shape()[k] == t0.shape()[k];
    if (!ok)
      throw Error("concat: shapes must match except in dim " + std::to_string(d) + ", got " + shapes_str(ts));
    out[d] += t.shape()[d];
  }
  Tensor r = Tensor::empty(out, t0.dtype());
  int64_t at = 0;
  for (const Tensor& t : ts) {
    Tensor dst = r.narrow(d, at, t.shape()[d]);
    detail::copy_strided(dst, t, "concat");
    at += t.shape()[d];
  }
  return r;
}

Tensor stack(const std::vector<Tensor>& ts, int64_t dim) {
  if (ts.empty()) throw Error("stack: empty list of tensors");
  for (const Tensor& t : ts) {
    detail::check_defined(t, "stack");
    if (t.shape() != ts[0].shape()) throw Error("stack: all shapes must be equal, got " + shapes_str(ts));
  }
  const int64_t d = wrap_dim(dim, ts[0].dim() + 1, "stack");
  std::vector<Tensor> u;
  u.reserve(ts.size());
  for (const Tensor& t : ts) u.push_back(t.unsqueeze(d));
  return concat(u, d);
}

std::vector<Tensor> split(const Tensor& a, const std::vector<int64_t>& sizes, int64_t dim) {
  detail::check_defined(a, "split");
  const int64_t d = wrap_dim(dim, a.dim(), "split");
  int64_t total = 0;
  for (int64_t s : sizes) {
    if (s < 0) throw Error("split: negative size in " + shape_str(sizes));
    total += s;
  }
  if (total != a.shape()[d])
    throw Error("split: sizes " + shape_str(sizes) + " sum to " + std::to_string(total) + ", dim " +
                std::to_string(d) + " of " + shape_str(a.shape()) + " has " + std::to_string(a.shape()[d]));
  std::vector<Tensor> r;
  int64_t at = 0;
  for (int64_t s : sizes) {
    r.push_back(a.narrow(d, at, s));
    at += s;
  }
  return r;
}

// torch semantics: chunk size ceil(n / chunks); the last chunk may be smaller and fewer chunks may come back.
std::vector<Tensor> chunk(const Tensor& a, int64_t chunks, int64_t dim) {
  detail::check_defined(a, "chunk");
  if (chunks <= 0) throw Error("chunk: chunks must be positive, got " + std::to_string(chunks));
  const int64_t d = wrap_dim(dim, a.dim(), "chunk");
  const int64_t n = a.shape()[d];
  const int64_t step = std::max<int64_t>(1, (n + chunks - 1) / chunks);
  std::vector<Tensor> r;
  for (int64_t at = 0; at < n; at += step) r.push_back(a.narrow(d, at, std::min(step, n - at)));
  if (n == 0) r.push_back(a);
  return r;
}

}  // namespace t2m
