// strided_iter.h — INTERNAL to tensor/: walks an n-d index space over N operands, each with its own strides.
//
// The index space is `shape` (row-major order). Operand k addresses element idx at base_k + sum_d idx[d] *
// strides[k][d] (strides in elements; 0 broadcasts). Before the walk the plan drops size-1 dims and merges
// neighbouring dims that are contiguous for every operand, so a contiguous same-shape op becomes one flat run.
// The kernel is called for runs along the innermost dim:
//     kernel(const std::array<int64_t, N>& offsets, const std::array<int64_t, N>& inner_strides, int64_t n)
// Large index spaces are split into equal linear ranges over OpenMP threads; each element is visited exactly
// once, so elementwise results do not depend on the thread count. Kernels must not throw.
#pragma once
#include <omp.h>

#include <algorithm>
#include <array>

#include "tensor/parallel.h"
#include "tensor/tensor.h"

namespace t2m::detail {

// Strides of t (elements) seen through numpy broadcasting to `shape`: t's dims align at the right, size-1 and
// missing dims get stride 0. Throws Error naming `op` when t's shape does not broadcast to `shape`.
inline Shape broadcast_strides(const Tensor& t, const Shape& shape, const char* op) {
  const int64_t nd = (int64_t)shape.size(), td = t.dim();
  if (td > nd)
    throw Error(std::string(op) + ": cannot broadcast " + shape_str(t.shape()) + " to " + shape_str(shape));
  Shape st(nd, 0);
  for (int64_t i = 0; i < td; ++i) {
    const int64_t d = nd - td + i;
    const int64_t s = t.shape()[i];
    if (s == shape[d]) st[d] = (s == 1) ? 0 : t.strides()[i];
    else if (s == 1) st[d] = 0;
    else throw Error(std::string(op) + ": cannot broadcast " + shape_str(t.shape()) + " to " + shape_str(shape));
  }
  return st;
}

template <size_t N>
struct StridedPlan {
  Shape shape;                    // coalesced; at least one dim
  std::array<Shape, N> strides;   // per operand, same length as shape
  int64_t numel = 0;
};

template <size_t N>
StridedPlan<N> make_plan(const Shape& shape, const std::array<Shape, N>& strides) {
  StridedPlan<N> p;
  p.numel = shape_numel(shape);
  // Keep non-trivial dims, outermost first.
  for (size_t d = 0; d < shape.size(); ++d) {
    if (shape[d] == 1) continue;
    if (!p.shape.empty()) {
      // Merge into the previous (outer) dim when that dim steps exactly over this one for every operand.
      bool mergeable = true;
      for (size_t k = 0; k < N; ++k)
        if (p.strides[k].back() != strides[k][d] * shape[d]) mergeable = false;
      if (mergeable) {
        p.shape.back() *= shape[d];
        for (size_t k = 0; k < N; ++k) p.strides[k].back() = strides[k][d];
        continue;
      }
    }
    p.shape.push_back(shape[d]);
    for (size_t k = 0; k < N; ++k) p.strides[k].push_back(strides[k][d]);
  }
  if (p.shape.empty()) {
    p.shape.push_back(1);
    for (size_t k = 0; k < N; ++k) p.strides[k].push_back(0);
  }
  return p;
}

// Runs the kernel over the linear index range [begin, end) of the plan.
template <size_t N, typename K>
void run_range(const StridedPlan<N>& p, int64_t begin, int64_t end, K& kernel) {
  if (begin >= end) return;
  const int64_t nd = (int64_t)p.shape.size();
  int64_t idx_small[16];
  std::vector<int64_t> idx_big;
  int64_t* idx = idx_small;
  if (nd > 16) { idx_big.resize(nd); idx = idx_big.data(); }
  std::array<int64_t, N> off{}, inner{};
  int64_t rem = begin;
  for (int64_t d = nd - 1; d >= 0; --d) {
    idx[d] = rem % p.shape[d];
    rem /= p.shape[d];
    for (size_t k = 0; k < N; ++k) off[k] += idx[d] * p.strides[k][d];
  }
  for (size_t k = 0; k < N; ++k) inner[k] = p.strides[k][nd - 1];
  const int64_t last = p.shape[nd - 1];
  int64_t pos = begin;
  while (pos < end) {
    const int64_t n = std::min(last - idx[nd - 1], end - pos);
    kernel(off, inner, n);
    pos += n;
    idx[nd - 1] += n;
    for (size_t k = 0; k < N; ++k) off[k] += n * inner[k];
    for (int64_t d = nd - 1; d > 0 && idx[d] == p.shape[d]; --d) {
      idx[d] = 0;
      ++idx[d - 1];
      for (size_t k = 0; k < N; ++k) off[k] += p.strides[k][d - 1] - p.shape[d] * p.strides[k][d];
    }
  }
}

// Number of threads for an elementwise op over n elements (1 below kParallelGrain).
inline int threads_for(int64_t n) {
  if (n < kParallelGrain) return 1;
  return (int)std::max<int64_t>(1, std::min<int64_t>(get_num_threads(), n / (kParallelGrain / 4)));
}

// Walks `shape` over N operands (see the file comment). parallel=false forces one thread (e.g. for scatters).
template <size_t N, typename K>
void strided_for_each(const Shape& shape, const std::array<Shape, N>& strides, K&& kernel, bool parallel = true) {
  const StridedPlan<N> p = make_plan<N>(shape, strides);
  if (p.numel == 0) return;
  const int nt = parallel ? threads_for(p.numel) : 1;
  if (nt <= 1) {
    run_range(p, 0, p.numel, kernel);
    return;
  }
#pragma omp parallel num_threads(nt)
  {
    const int64_t t = omp_get_thread_num(), T = omp_get_num_threads();
    run_range(p, p.numel * t / T, p.numel * (t + 1) / T, kernel);
  }
}

}  // namespace t2m::detail
