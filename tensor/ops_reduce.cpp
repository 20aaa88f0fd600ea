// ops_reduce.cpp — sum, mean, amax, amin, logsumexp, max/argmax, sum_to (engine in reduce_iter.h).
#include <cmath>
#include <limits>

#include "tensor/kernels.h"
#include "tensor/ops.h"
#include "tensor/reduce_iter.h"

namespace t2m {
namespace {

using detail::dispatch_float;
using detail::ReduceGeom;

// Reduces with Op<T> and writes finish(acc) into a fresh tensor of the output shape.
template <template <typename> class Op, typename Finish>
Tensor reduce_with(const Tensor& a, const ReduceGeom& g, const char* op, Finish finish) {
  Tensor out = Tensor::empty(g.out_shape, a.dtype());
  dispatch_float(a.dtype(), op, [&](auto z) {
    using T = decltype(z);
    const auto acc = detail::reduce_accumulate<Op<T>, T>(a.data<T>(), g);
    T* po = out.data<T>();
    for (int64_t o = 0; o < g.n_out; ++o) po[o] = (T)finish(acc[o]);
  });
  return out;
}

template <typename T> using MaxOp = detail::ExtremeOp<T, 1>;
template <typename T> using MinOp = detail::ExtremeOp<T, -1>;

void check_nonempty(const Tensor& a, const ReduceGeom& g, const char* op) {
  if (g.n_red == 0 && g.n_out > 0)
    throw Error(std::string(op) + ": cannot reduce over an empty dim of shape " + shape_str(a.shape()));
}

}  // namespace

Tensor sum(const Tensor& a, const std::vector<int64_t>& dims, bool keepdim) {
  detail::check_defined(a, "sum");
  const ReduceGeom g = detail::reduce_geom(a, dims, keepdim, true, "sum");
  return reduce_with<detail::SumOp>(a, g, "sum", [](double s) { return s; });
}

Tensor mean(const Tensor& a, const std::vector<int64_t>& dims, bool keepdim) {
  detail::check_defined(a, "mean");
  const ReduceGeom g = detail::reduce_geom(a, dims, keepdim, true, "mean");
  const double n = (double)g.n_red;  // empty reduction gives 0/0 = NaN, like torch
  return reduce_with<detail::SumOp>(a, g, "mean", [n](double s) { return s / n; });
}

Tensor amax(const Tensor& a, const std::vector<int64_t>& dims, bool keepdim) {
  detail::check_defined(a, "amax");
  const ReduceGeom g = detail::reduce_geom(a, dims, keepdim, true, "amax");
  check_nonempty(a, g, "amax");
  return reduce_with<MaxOp>(a, g, "amax", [](auto m) { return m; });
}

Tensor amin(const Tensor& a, const std::vector<int64_t>& dims, bool keepdim) {
  detail::check_defined(a, "amin");
  const ReduceGeom g = detail::reduce_geom(a, dims, keepdim, true, "amin");
  check_nonempty(a, g, "amin");
  return reduce_with<MinOp>(a, g, "amin", [](auto m) { return m; });
}

// log sum_i exp(x_i) = m + log sum_i exp(x_i - m), m = max_i x_i (m replaced by 0 when it is +-inf or NaN, so
// all -inf gives -inf and a +inf entry gives +inf instead of NaN from inf - inf).
Tensor logsumexp(const Tensor& a, int64_t dim, bool keepdim) {
  detail::check_defined(a, "logsumexp");
  const int64_t d = wrap_dim(dim, a.dim(), "logsumexp");
  if (a.shape()[d] == 0) {  // log(0) = -inf, like torch
    Tensor s = sum(a, {d}, keepdim);
    s.fill_(-std::numeric_limits<double>::infinity());
    return s;
  }
  Tensor m = amax(a, {d}, true);
  m = detail::map_unary(m, "logsumexp", [](auto x) { return std::isfinite(x) ? x : decltype(x)(0); });
  Tensor s = log(sum(exp(sub(a, m)), {d}, true));
  Tensor r = add(s, m);
  return keepdim ? r : r.squeeze(d);
}

MaxResult max(const Tensor& a, int64_t dim, bool keepdim) {
  detail::check_defined(a, "max");
  const int64_t d = wrap_dim(dim, a.dim(), "max");
  const ReduceGeom g = detail::reduce_geom(a, {d}, keepdim, false, "max");
  check_nonempty(a, g, "max");
  MaxResult r{Tensor::empty(g.out_shape, a.dtype()), Tensor::empty(g.out_shape, DType::i64)};
  const auto kept = detail::make_plan<2>(g.kept_shape, {contiguous_strides(g.kept_shape), g.kept_strides});
  const int64_t n = a.shape()[d], s = a.strides()[d];
  dispatch_float(a.dtype(), "max", [&](auto z) {
    using T = decltype(z);
    const T* pa = a.data<T>();
    T* pv = r.values.data<T>();
    int64_t* pi = r.indices.data<int64_t>();
    auto k = [&](const std::array<int64_t, 2>& off, const std::array<int64_t, 2>& st, int64_t cnt) {
      for (int64_t j = 0; j < cnt; ++j) {
        const T* x = pa + off[1] + j * st[1];
        T best = x[0];
        int64_t bi = 0;
        for (int64_t i = 1; i < n && best == best; ++i) {
          const T v = x[i * s];
          if (v > best || v != v) {  // strict: the first maximum wins; the first NaN wins outright
            best = v;
            bi = i;
          }
        }
        pv[off[0] + j * st[0]] = best;
        pi[off[0] + j * st[0]] = bi;
      }
    };
    const int nt = detail::threads_for(g.n_out * n);
    if (nt <= 1 || g.n_out < 2) {
      detail::run_range(kept, 0, g.n_out, k);
    } else {
#pragma omp parallel num_threads(nt)
      {
        const int64_t t = omp_get_thread_num(), T_ = omp_get_num_threads();
        detail::run_range(kept, g.n_out * t / T_, g.n_out * (t + 1) / T_, k);
      }
    }
  });
  return r;
}

Tensor argmax(const Tensor& a, int64_t dim, bool keepdim) { return max(a, dim, keepdim).indices; }

Tensor sum_to(const Tensor& a, const Shape& shape) {
  detail::check_defined(a, "sum_to");
  const int64_t lead = a.dim() - (int64_t)shape.size();
  bool ok = lead >= 0;
  std::vector<int64_t> dims;
  for (int64_t d = 0; ok && d < a.dim(); ++d) {
    if (d < lead) {
      dims.push_back(d);
      continue;
    }
    const int64_t want = shape[d - lead], have = a.shape()[d];
    if (want == have) continue;
    if (want == 1) dims.push_back(d);
    else ok = false;
  }
  if (!ok) throw Error("sum_to: cannot sum " + shape_str(a.shape()) + " to " + shape_str(shape));
  if (dims.empty()) return a.clone();
  const ReduceGeom g = detail::reduce_geom(a, dims, true, false, "sum_to");
  return reduce_with<detail::SumOp>(a, g, "sum_to", [](double s) { return s; }).view(shape);
}

}  // namespace t2m
