// rng.cpp — Philox4x32-10 (Salmon et al., "Parallel random numbers: as easy as 1, 2, 3", SC'11) and the
// distributions built on it.
//
// Counter layout: a draw of n values reserves ceil(n / per) counters from the Generator (per = values made from
// one 4-word block: 4 for f32 uniform/normal/bernoulli, 2 for f64 uniform/normal and randint). Value i comes
// from counter offset + i / per, words of slot i % per. The block for counter c is philox(key = seed,
// ctr = {lo32(c), hi32(c), 0, 0}); blocks are independent, so any thread split gives the same numbers.
#include "tensor/rng.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "tensor/kernels.h"
#include "tensor/rng_philox.h"

namespace t2m {
namespace {

using rng_detail::kPhiloxM0;
using rng_detail::kPhiloxM1;
using rng_detail::kPhiloxW0;
using rng_detail::kPhiloxW1;
constexpr double kTwoPi = 6.283185307179586476925286766559;

// One Philox S-box round: two 32x32->64 multiplies, then the word permutation with key mixing.
inline void philox_round(uint32_t c[4], const uint32_t k[2]) {
  const uint64_t p0 = (uint64_t)kPhiloxM0 * c[0];
  const uint64_t p1 = (uint64_t)kPhiloxM1 * c[2];
  const uint32_t hi0 = (uint32_t)(p0 >> 32), lo0 = (uint32_t)p0;
  const uint32_t hi1 = (uint32_t)(p1 >> 32), lo1 = (uint32_t)p1;
  const uint32_t n0 = hi1 ^ c[1] ^ k[0], n2 = hi0 ^ c[3] ^ k[1];
  c[0] = n0;
  c[1] = lo1;
  c[2] = n2;
  c[3] = lo0;
}

// 24-bit uniform in [0, 1) and in (0, 1] (for logs).
inline float u24(uint32_t w) { return (float)(w >> 8) * (1.0f / 16777216.0f); }
inline double u24_open0(uint32_t w) { return ((double)(w >> 8) + 1.0) * (1.0 / 16777216.0); }
// 53-bit uniform in [0, 1) from two words, and in (0, 1].
inline double u53(uint32_t a, uint32_t b) {
  return ((double)(a >> 5) * 67108864.0 + (double)(b >> 6)) * (1.0 / 9007199254740992.0);
}
inline double u53_open0(uint32_t a, uint32_t b) {
  return ((double)(a >> 5) * 67108864.0 + (double)(b >> 6) + 1.0) * (1.0 / 9007199254740992.0);
}

// Fills n values: for counter c, make(words, dst, count) writes up to `per` values. Parallel over counters.
template <typename T, typename Make>
void fill_blocks(T* dst, int64_t n, uint64_t seed, uint64_t base, int64_t per, Make make) {
  const int64_t nc = (n + per - 1) / per;
  constexpr int64_t kChunk = 64;  // counters generated at once (philox4x32_blocks: 16 per AVX-512 step)
  const int64_t nch = (nc + kChunk - 1) / kChunk;
  const int nt = detail::threads_for(n);
#pragma omp parallel for if (nt > 1) num_threads(nt) schedule(static)
  for (int64_t ch = 0; ch < nch; ++ch) {
    uint32_t w[4 * kChunk];
    const int64_t c0 = ch * kChunk, cnt = std::min(kChunk, nc - c0);
    philox4x32_blocks(seed, base + (uint64_t)c0, cnt, w);
    for (int64_t c = c0; c < c0 + cnt; ++c) make(w + 4 * (c - c0), dst + c * per, std::min(per, n - c * per));
  }
}

void check_float_dtype(DType dt, const char* op) {
  if (dt == DType::i64) throw Error(std::string(op) + ": dtype i64 is not supported (needs f32 or f64)");
}

}  // namespace

void philox4x32_block(const uint32_t ctr[4], const uint32_t key[2], uint32_t out[4]) {
  uint32_t c[4] = {ctr[0], ctr[1], ctr[2], ctr[3]};
  uint32_t k[2] = {key[0], key[1]};
  for (int r = 0; r < 10; ++r) {
    if (r > 0) {
      k[0] += kPhiloxW0;
      k[1] += kPhiloxW1;
    }
    philox_round(c, k);
  }
  for (int i = 0; i < 4; ++i) out[i] = c[i];
}

namespace rng_detail {
void philox4x32_blocks_avx512(uint64_t seed, uint64_t counter0, int64_t n16, uint32_t* out);  // rng_avx512.cpp
}  // namespace rng_detail

void philox4x32_blocks(uint64_t seed, uint64_t counter0, int64_t nblocks, uint32_t* out) {
  static const bool avx512 = __builtin_cpu_supports("avx512f");
  int64_t done = 0;
  if (avx512 && nblocks >= 16) {
    rng_detail::philox4x32_blocks_avx512(seed, counter0, nblocks / 16, out);
    done = nblocks / 16 * 16;
  }
  for (int64_t b = done; b < nblocks; ++b) philox4x32(seed, counter0 + (uint64_t)b, out + 4 * b);
}

void philox4x32(uint64_t seed, uint64_t counter, uint32_t out[4]) {
  const uint32_t ctr[4] = {(uint32_t)counter, (uint32_t)(counter >> 32), 0u, 0u};
  const uint32_t key[2] = {(uint32_t)seed, (uint32_t)(seed >> 32)};
  philox4x32_block(ctr, key, out);
}

Tensor rand_uniform(const Shape& shape, Generator& gen, double lo, double hi, DType dtype) {
  check_float_dtype(dtype, "rand_uniform");
  if (!(lo <= hi)) throw Error("rand_uniform: lo " + std::to_string(lo) + " > hi " + std::to_string(hi));
  Tensor t = Tensor::empty(shape, dtype);
  const int64_t n = t.numel();
  if (dtype == DType::f32) {
    const float flo = (float)lo, fhi = (float)hi, span = (float)(hi - lo);
    const float top = flo < fhi ? std::nextafter(fhi, flo) : fhi;  // keep [lo, hi) after rounding
    const uint64_t base = gen.advance((uint64_t)(n + 3) / 4);
    fill_blocks(t.data<float>(), n, gen.seed(), base, 4, [=](const uint32_t* w, float* d, int64_t k) {
      for (int64_t i = 0; i < 4 && i < k; ++i) d[i] = std::min(top, flo + span * u24(w[i]));
    });
  } else {
    const double top = lo < hi ? std::nextafter(hi, lo) : hi;
    const uint64_t base = gen.advance((uint64_t)(n + 1) / 2);
    fill_blocks(t.data<double>(), n, gen.seed(), base, 2, [=](const uint32_t* w, double* d, int64_t k) {
      for (int64_t i = 0; i < 2 && i < k; ++i) d[i] = std::min(top, lo + (hi - lo) * u53(w[2 * i], w[2 * i + 1]));
    });
  }
  return t;
}

// Box-Muller: z0 = r cos(2 pi u2), z1 = r sin(2 pi u2), r = sqrt(-2 ln u1), u1 in (0, 1].
Tensor rand_normal(const Shape& shape, Generator& gen, double mean, double std, DType dtype) {
  check_float_dtype(dtype, "rand_normal");
  if (!(std >= 0)) throw Error("rand_normal: std must be >= 0, got " + std::to_string(std));
  Tensor t = Tensor::empty(shape, dtype);
  const int64_t n = t.numel();
  if (dtype == DType::f32) {
    const uint64_t base = gen.advance((uint64_t)(n + 3) / 4);
    fill_blocks(t.data<float>(), n, gen.seed(), base, 4, [=](const uint32_t* w, float* d, int64_t k) {
      const float fm = (float)mean, fs = (float)std;
      for (int64_t p = 0; p < 2 && 2 * p < k; ++p) {  // float math: the output has 24-bit precision anyway
        const float r = std::sqrt(-2.0f * std::log((float)u24_open0(w[2 * p])));
        const float th = (float)kTwoPi * u24(w[2 * p + 1]);
        d[2 * p] = fm + fs * r * std::cos(th);
        if (2 * p + 1 < k) d[2 * p + 1] = fm + fs * r * std::sin(th);
      }
    });
  } else {
    const uint64_t base = gen.advance((uint64_t)(n + 1) / 2);
    fill_blocks(t.data<double>(), n, gen.seed(), base, 2, [=](const uint32_t* w, double* d, int64_t k) {
      const double r = std::sqrt(-2.0 * std::log(u53_open0(w[0], w[1])));
      const double th = kTwoPi * u53(w[2], w[3]);
      d[0] = mean + std * r * std::cos(th);
      if (k > 1) d[1] = mean + std * r * std::sin(th);
    });
  }
  return t;
}

// value = 1 when w / 2^32 < p (32-bit resolution).
Tensor rand_bernoulli(const Shape& shape, Generator& gen, double p, DType dtype) {
  if (!(p >= 0.0 && p <= 1.0)) throw Error("rand_bernoulli: p must be in [0, 1], got " + std::to_string(p));
  Tensor t = Tensor::empty(shape, dtype);
  const int64_t n = t.numel();
  const uint64_t base = gen.advance((uint64_t)(n + 3) / 4);
  const double scale = 1.0 / 4294967296.0;
  detail::dispatch_all(dtype, [&](auto z) {
    using T = decltype(z);
    fill_blocks(t.data<T>(), n, gen.seed(), base, 4, [=](const uint32_t* w, T* d, int64_t k) {
      for (int64_t i = 0; i < 4 && i < k; ++i) d[i] = (T)((double)w[i] * scale < p ? 1 : 0);
    });
  });
  return t;
}

// value = lo + (64-bit draw mod (hi - lo)); the modulo bias is below range / 2^64.
Tensor randint(const Shape& shape, Generator& gen, int64_t lo, int64_t hi) {
  if (hi <= lo) throw Error("randint: need lo < hi, got [" + std::to_string(lo) + ", " + std::to_string(hi) + ")");
  Tensor t = Tensor::empty(shape, DType::i64);
  const int64_t n = t.numel();
  const uint64_t range = (uint64_t)hi - (uint64_t)lo;
  const uint64_t base = gen.advance((uint64_t)(n + 1) / 2);
  fill_blocks(t.data<int64_t>(), n, gen.seed(), base, 2, [=](const uint32_t* w, int64_t* d, int64_t k) {
    for (int64_t i = 0; i < 2 && i < k; ++i) {
      const uint64_t r = ((uint64_t)w[2 * i] << 32) | w[2 * i + 1];
      d[i] = (int64_t)((uint64_t)lo + r % range);
    }
  });
  return t;
}

// Fisher-Yates from the back: step s (s = 0 .. n-2) swaps p[i] with p[j], i = n-1-s, j uniform in [0, i],
// using 64-bit draw s of the stream (counter offset + s / 2).
std::vector<int64_t> randperm(int64_t n, Generator& gen) {
  if (n < 0) throw Error("randperm: n must be >= 0, got " + std::to_string(n));
  std::vector<int64_t> p(n);
  std::iota(p.begin(), p.end(), 0);
  if (n < 2) return p;
  const uint64_t steps = (uint64_t)n - 1;
  const uint64_t base = gen.advance((steps + 1) / 2);
  uint32_t w[4] = {0, 0, 0, 0};
  for (uint64_t s = 0; s < steps; ++s) {
    if (s % 2 == 0) philox4x32(gen.seed(), base + s / 2, w);
    const uint64_t r = ((uint64_t)w[2 * (s % 2)] << 32) | w[2 * (s % 2) + 1];
    const int64_t i = n - 1 - (int64_t)s;
    const int64_t j = (int64_t)(r % (uint64_t)(i + 1));
    std::swap(p[i], p[j]);
  }
  return p;
}

}  // namespace t2m
