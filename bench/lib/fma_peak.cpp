// fma_peak.cpp — 12 independent FMA chains per thread in an OpenMP region, timed on the wall clock; the chains'
// results are summed into a value the caller cannot ignore, so the loop is not optimised away.
#include "bench/lib/fma_peak.h"

#include <omp.h>

#include <algorithm>
#include <cstdint>

#include "tensor/cpu_features.h"

namespace t2m::bench {

namespace {

constexpr int kChains = 12;

typedef float F16 __attribute__((vector_size(64)));  // a zmm register
typedef float F8 __attribute__((vector_size(32)));   // a ymm register

// kChains chains of acc = acc * a + b (contracted to one FMA) over Vec registers; returns the lanes' sum. Generic
// vector code, inlined into a caller compiled for the ISA whose registers Vec fills.
template <typename Vec>
[[gnu::always_inline]] inline float chains(int64_t iters, float seed) {
  Vec acc[kChains];
  for (int i = 0; i < kChains; ++i) acc[i] = Vec{} + seed * float(i + 1);
  const Vec a = Vec{} + 0.999999f, b = Vec{} + 1e-7f;
  for (int64_t it = 0; it < iters; ++it)
    for (int i = 0; i < kChains; ++i) acc[i] = acc[i] * a + b;
  Vec s = acc[0];
  for (int i = 1; i < kChains; ++i) s += acc[i];
  float r = 0;
  for (size_t l = 0; l < sizeof(Vec) / sizeof(float); ++l) r += s[l];
  return r;
}

__attribute__((target("avx512f"))) float chains_avx512(int64_t iters, float seed) { return chains<F16>(iters, seed); }
float chains_avx2(int64_t iters, float seed) { return chains<F8>(iters, seed); }  // the x86-64-v3 baseline

}  // namespace

double fma_peak_gflops(int threads, int tries) {
  const bool wide = cpu_has_avx512();
  const int lanes = wide ? 16 : 8;
  const int64_t iters = 8'000'000 / lanes * 16;  // 3 GFLOP per thread: ~27 ms at 115 GFLOP/s
  const double flops = double(iters) * kChains * lanes * 2 * threads;
  double best = 0;
  static volatile float sink = 0;
  for (int k = 0; k < std::max(tries, 1); ++k) {
    float total = 0;
    const double t0 = omp_get_wtime();
#pragma omp parallel num_threads(threads) reduction(+ : total)
    total += wide ? chains_avx512(iters, 1e-3f * float(omp_get_thread_num() + 1))
                  : chains_avx2(iters, 1e-3f * float(omp_get_thread_num() + 1));
    const double s = omp_get_wtime() - t0;
    sink = sink + total;
    best = std::max(best, flops / s / 1e9);
  }
  return best;
}

}  // namespace t2m::bench
