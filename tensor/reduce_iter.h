// reduce_iter.h — INTERNAL to tensor/: the reduction engine behind sum/mean/amax/amin (ops_reduce.cpp).
//
// Summation order (documented choice): float32 and float64 sums accumulate in double. The reduced elements of
// one output are cut into fixed blocks of kReduceBlock elements (in row-major order of the reduced dims); each
// block is summed with 8 interleaved accumulators, and block partials are added in block order. Blocks run in
// parallel, so the result does not depend on the thread count at all.
// Layouts where the reduced dims lie outside a contiguous kept innermost dim (e.g. summing [N, C] over N) use
// a column pass instead: acc[c] += x[r, c] for r in order, threads split the columns — also thread-count free.
#pragma once
#include <omp.h>

#include <algorithm>
#include <limits>
#include <vector>

#include "tensor/strided_iter.h"

namespace t2m::detail {

constexpr int64_t kReduceBlock = 8192;

// Geometry of a reduction of `a` over `dims`.
struct ReduceGeom {
  Shape out_shape;                  // keepdim applied
  Shape kept_shape, kept_strides;   // input geometry of the kept dims, in order
  Shape red_shape, red_strides;     // input geometry of the reduced dims, in order
  int64_t n_out = 1, n_red = 1;
  bool column_pass = false;         // see the file comment
};

// dims may be negative; duplicates throw. all_if_empty: an empty dims list reduces every dim.
inline ReduceGeom reduce_geom(const Tensor& a, const std::vector<int64_t>& dims, bool keepdim, bool all_if_empty,
                              const char* op) {
  const int64_t nd = a.dim();
  std::vector<bool> red(nd, false);
  if (dims.empty() && all_if_empty) std::fill(red.begin(), red.end(), true);
  for (int64_t d : dims) {
    const int64_t w = wrap_dim(d, nd, op);
    if (red[w]) throw Error(std::string(op) + ": dim " + std::to_string(d) + " repeated in reduction of shape " +
                            shape_str(a.shape()));
    red[w] = true;
  }
  ReduceGeom g;
  for (int64_t d = 0; d < nd; ++d) {
    if (red[d]) {
      g.red_shape.push_back(a.shape()[d]);
      g.red_strides.push_back(a.strides()[d]);
      if (keepdim) g.out_shape.push_back(1);
    } else {
      g.kept_shape.push_back(a.shape()[d]);
      g.kept_strides.push_back(a.strides()[d]);
      g.out_shape.push_back(a.shape()[d]);
    }
  }
  g.n_out = shape_numel(g.kept_shape);
  g.n_red = shape_numel(g.red_shape);
  g.column_pass = nd > 0 && !red[nd - 1] && a.strides()[nd - 1] == 1 && a.shape()[nd - 1] >= 16 && g.n_red > 1;
  return g;
}

// Op: Acc init(); void run(Acc&, const T* p, int64_t stride, int64_t n); void merge(Acc&, const Acc&);
//     void step(Acc&, T x). Returns one Acc per output (row-major over the kept dims).
template <typename Op, typename T>
std::vector<typename Op::Acc> reduce_accumulate(const T* in, const ReduceGeom& g) {
  using Acc = typename Op::Acc;
  std::vector<Acc> out(g.n_out, Op::init());
  if (g.n_out == 0 || g.n_red == 0) return out;
  const int64_t total = g.n_out * g.n_red;
  const auto kept = make_plan<2>(g.kept_shape, {contiguous_strides(g.kept_shape), g.kept_strides});
  const auto redp = make_plan<1>(g.red_shape, {g.red_strides});

  if (g.column_pass) {
    const int nt = (int)std::max<int64_t>(1, std::min<int64_t>(threads_for(total), g.n_out / 16));
#pragma omp parallel if (nt > 1) num_threads(nt)
    {
      const int64_t t = omp_get_thread_num(), T_ = omp_get_num_threads();
      const int64_t o0 = g.n_out * t / T_, o1 = g.n_out * (t + 1) / T_;
      Acc* acc = out.data();
      auto per_row = [&](const std::array<int64_t, 1>& roff, const std::array<int64_t, 1>& rst, int64_t rn) {
        for (int64_t j = 0; j < rn; ++j) {
          const T* row = in + roff[0] + j * rst[0];
          auto cols = [&](const std::array<int64_t, 2>& off, const std::array<int64_t, 2>& st, int64_t n) {
            Acc* a = acc + off[0];
            const T* x = row + off[1];
            if (st[0] == 1 && st[1] == 1)
              for (int64_t i = 0; i < n; ++i) Op::step(a[i], x[i]);
            else
              for (int64_t i = 0; i < n; ++i) Op::step(a[i * st[0]], x[i * st[1]]);
          };
          run_range(kept, o0, o1, cols);
        }
      };
      if (o1 > o0) run_range(redp, 0, g.n_red, per_row);
    }
    return out;
  }

  const int64_t nblocks = (g.n_red + kReduceBlock - 1) / kReduceBlock;
  const int nt = threads_for(total);
  // Input offset of output o (row-major over the kept dims).
  auto out_offset = [&](int64_t o) {
    int64_t off = 0;
    for (int64_t d = (int64_t)kept.shape.size() - 1; d >= 0; --d) {
      off += (o % kept.shape[d]) * kept.strides[1][d];
      o /= kept.shape[d];
    }
    return off;
  };
  auto block = [&](int64_t base, int64_t b) {
    Acc acc = Op::init();
    auto k = [&](const std::array<int64_t, 1>& off, const std::array<int64_t, 1>& st, int64_t n) {
      Op::run(acc, in + base + off[0], st[0], n);
    };
    run_range(redp, b * kReduceBlock, std::min(g.n_red, (b + 1) * kReduceBlock), k);
    return acc;
  };
  if (nblocks == 1) {
#pragma omp parallel for if (nt > 1) num_threads(nt) schedule(static)
    for (int64_t o = 0; o < g.n_out; ++o) out[o] = block(out_offset(o), 0);
    return out;
  }
  std::vector<Acc> partial(g.n_out * nblocks);
  const int64_t items = g.n_out * nblocks;
#pragma omp parallel for if (nt > 1) num_threads(nt) schedule(static)
  for (int64_t it = 0; it < items; ++it) partial[it] = block(out_offset(it / nblocks), it % nblocks);
  for (int64_t o = 0; o < g.n_out; ++o) {
    Acc acc = partial[o * nblocks];
    for (int64_t b = 1; b < nblocks; ++b) Op::merge(acc, partial[o * nblocks + b]);
    out[o] = acc;
  }
  return out;
}

// Sum in double with 8 interleaved accumulators on unit stride.
template <typename T>
struct SumOp {
  using Acc = double;
  static Acc init() { return 0.0; }
  static void step(Acc& a, T x) { a += (double)x; }
  static void merge(Acc& a, const Acc& b) { a += b; }
  static void run(Acc& a, const T* p, int64_t s, int64_t n) {
    if (s != 1) {
      double acc = 0;
      for (int64_t i = 0; i < n; ++i) acc += (double)p[i * s];
      a += acc;
      return;
    }
    double r[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    int64_t i = 0;
    for (; i + 8 <= n; i += 8)
      for (int j = 0; j < 8; ++j) r[j] += (double)p[i + j];
    for (; i < n; ++i) r[i & 7] += (double)p[i];
    a += ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
  }
};

// Max (Sign = +1) or min (Sign = -1); NaN wins (propagates).
template <typename T, int Sign>
struct ExtremeOp {
  using Acc = T;
  static Acc init() { return Sign > 0 ? -std::numeric_limits<T>::infinity() : std::numeric_limits<T>::infinity(); }
  static void step(Acc& a, T x) {
    if (x != x || (Sign > 0 ? x > a : x < a)) a = x;
  }
  static void merge(Acc& a, const Acc& b) {
    if (a != a) return;
    step(a, b);
  }
  static void run(Acc& a, const T* p, int64_t s, int64_t n) {
    if (a != a) return;
    for (int64_t i = 0; i < n; ++i) {
      step(a, p[i * s]);
      if (a != a) return;
    }
  }
};

}  // namespace t2m::detail
