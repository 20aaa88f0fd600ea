// mem_bandwidth.cpp — the triad over arrays far larger than any cache, split statically over the threads.
#include "bench/lib/mem_bandwidth.h"

#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <memory>

#include "tensor/allocator.h"
#include "tensor/tensor.h"

namespace t2m::bench {

double triad_gbps(int threads, int tries) {
  const int64_t n = int64_t{16} << 20;  // floats per array: 64 MB
  // On 2 MB pages where the kernel gives them, as the tensors' own blocks (tensor/allocator.h): the probe then
  // measures the memory, not the TLB.
  struct Free {
    void operator()(float* p) const { std::free(p); }
  };
  auto alloc = [n] {
    float* p = static_cast<float*>(aligned_alloc_pages(size_t(n) * sizeof(float), 64));
    if (!p) throw Error("triad_gbps: out of memory");
    return std::unique_ptr<float[], Free>(p);
  };
  const auto a = alloc(), b = alloc(), c = alloc();
  float* const pa = a.get();
  float* const pb = b.get();
  float* const pc = c.get();
  for (int64_t i = 0; i < n; ++i) {
    pa[i] = 1.0f;
    pb[i] = 2.0f;
  }
  double best = 0;
  for (int t = -1; t < tries; ++t) {  // t = -1: the untimed pass (c's first touch)
    const auto t0 = std::chrono::steady_clock::now();
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int64_t i = 0; i < n; ++i) pc[i] = pa[i] + 0.5f * pb[i];
    const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (t >= 0 && sec > 0 && 12.0 * double(n) / sec * 1e-9 > best) best = 12.0 * double(n) / sec * 1e-9;
    pa[t + 1] = pc[n - 1 - (t + 1)];  // each pass depends on the last: nothing to hoist
  }
  return best;
}

}  // namespace t2m::bench
