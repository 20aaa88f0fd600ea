// mem_bandwidth.cpp — the triad over arrays far larger than any cache, split statically over the threads.
#include "bench/lib/mem_bandwidth.h"

#include <omp.h>

#include <chrono>
#include <cstdint>
#include <vector>

namespace t2m::bench {

double triad_gbps(int threads, int tries) {
  const int64_t n = int64_t{16} << 20;  // floats per array: 64 MB
  std::vector<float> a(n, 1.0f), b(n, 2.0f), c(n, 0.0f);
  float* const pa = a.data();
  const float* const pb = b.data();
  float* const pc = c.data();
  double best = 0;
  for (int t = -1; t < tries; ++t) {  // t = -1: the untimed pass
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
