// kernel_util.h — INTERNAL to tensor/fused/: argument checks, the thread decision and row partitioning shared by
// the fused kernels.
//
// check_dim throws t2m::Error "op: name must be >= min, got v"; check_ptr throws when a required pointer is null.
// fused_threads(work) is 1 below t2m::kParallelGrain elements of work, else t2m::get_num_threads().
// add_to_partials16 / sum_partials16: a fixed-order 16-way partial sum (vectorises).
// row_range(n, tid, nt) is the contiguous, fixed block of [0, n) that thread tid of nt owns: the split depends
// only on (n, nt), so a kernel that reduces per-thread partials in thread order is deterministic per thread count.
#pragma once
#include <cstdint>
#include <string>
#include <utility>

#include "tensor/parallel.h"
#include "tensor/tensor.h"

namespace t2m::fused {

inline void check_dim(const char* op, const char* name, int64_t v, int64_t min = 1) {
  if (v < min)
    throw Error(std::string(op) + ": " + name + " must be >= " + std::to_string(min) + ", got " + std::to_string(v));
}

inline void check_ptr(const char* op, const char* name, const void* p) {
  if (p == nullptr) throw Error(std::string(op) + ": " + name + " is null");
}

inline int fused_threads(int64_t work) {
  if (work < kParallelGrain) return 1;
  int nt = get_num_threads();
  return nt < 1 ? 1 : nt;
}

inline std::pair<int64_t, int64_t> row_range(int64_t n, int tid, int nt) {
  return {n * tid / nt, n * (tid + 1) / nt};
}

// Sums x[0, n) into 16 running partial sums (element t into part[t % 16]): a vectorisable reduction whose order
// depends only on n. Add the partials with sum_partials16 at the end (conv bias gradients).
template <typename T>
inline void add_to_partials16(T (&part)[16], const T* x, int64_t n) {
  int64_t t = 0;
  for (; t + 16 <= n; t += 16)
    for (int k = 0; k < 16; ++k) part[k] += x[t + k];
  for (; t < n; ++t) part[t % 16] += x[t];
}

template <typename T>
inline T sum_partials16(const T (&part)[16]) {
  T sum = 0;
  for (T v : part) sum += v;
  return sum;
}

}  // namespace t2m::fused
