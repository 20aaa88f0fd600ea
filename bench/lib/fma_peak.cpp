// fma_peak.cpp — 12 independent FMA chains per thread in an OpenMP region, timed on the wall clock; the chains'
// results are summed into a value the caller cannot ignore, so the loop is not optimised away.
#include "bench/lib/fma_peak.h"

#include <immintrin.h>
#include <omp.h>

#include <algorithm>
#include <cstdint>

#include "tensor/cpu_features.h"

namespace t2m::bench {

namespace {

constexpr int kChains = 12;

// 16 lanes x 2 flops x kChains per iteration.
__attribute__((target("avx512f"))) float chains_avx512(int64_t iters, float seed) {
  __m512 acc[kChains];
  for (int i = 0; i < kChains; ++i) acc[i] = _mm512_set1_ps(seed * float(i + 1));
  const __m512 a = _mm512_set1_ps(0.999999f), b = _mm512_set1_ps(1e-7f);
  for (int64_t it = 0; it < iters; ++it)
    for (int i = 0; i < kChains; ++i) acc[i] = _mm512_fmadd_ps(acc[i], a, b);
  __m512 s = acc[0];
  for (int i = 1; i < kChains; ++i) s = _mm512_add_ps(s, acc[i]);
  float lanes[16];
  _mm512_storeu_ps(lanes, s);
  float r = 0;
  for (float x : lanes) r += x;
  return r;
}

// 8 lanes x 2 flops x kChains per iteration.
__attribute__((target("avx2,fma"))) float chains_avx2(int64_t iters, float seed) {
  __m256 acc[kChains];
  for (int i = 0; i < kChains; ++i) acc[i] = _mm256_set1_ps(seed * float(i + 1));
  const __m256 a = _mm256_set1_ps(0.999999f), b = _mm256_set1_ps(1e-7f);
  for (int64_t it = 0; it < iters; ++it)
    for (int i = 0; i < kChains; ++i) acc[i] = _mm256_fmadd_ps(acc[i], a, b);
  __m256 s = acc[0];
  for (int i = 1; i < kChains; ++i) s = _mm256_add_ps(s, acc[i]);
  float lanes[8];
  _mm256_storeu_ps(lanes, s);
  float r = 0;
  for (float x : lanes) r += x;
  return r;
}

}  // namespace

double fma_peak_gflops(int threads, int tries) {
  const bool wide = cpu_has_avx512();
  const int lanes = wide ? 16 : 8;
  const int64_t iters = 8'000'000 / lanes * 16;  // ~50 ms per thread at 100+ GFLOP/s
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
