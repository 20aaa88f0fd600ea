// rng_avx512.cpp — Philox4x32-10 on 16 counters at once (AVX-512F; compiled with AVX-512 flags, called only
// when the CPU has it, see philox4x32_blocks in rng.cpp). Same words as the scalar philox4x32, bit for bit.
#include <immintrin.h>

#include <cstdint>

#include "tensor/rng_philox.h"

// GCC 12's AVX-512 headers build shift/unpack/shuffle results on a self-initialised "undefined" vector, which
// -Wmaybe-uninitialized (and, for _mm512_shuffle_epi32, -Wuninitialized) reports once inlined here (a known false
// positive).
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"

namespace t2m::rng_detail {

namespace {

// hi and lo 32-bit halves of the 16 lane products a * m (m_odd: m with its odd lanes moved to the even ones): two
// 32 x 32 -> 64-bit multiplies (the even lanes, then the odd ones swapped down), and each half gathered from both by
// one two-source permute: fewer port-0/5 operations than shifting and blending the halves into place (with two
// groups in flight, BM_philox_blocks 1.76 -> 2.09 G words/s on the Intel host).
struct HiLoIndex {
  __m512i lo = _mm512_setr_epi32(0, 16, 2, 18, 4, 20, 6, 22, 8, 24, 10, 26, 12, 28, 14, 30);
  __m512i hi = _mm512_setr_epi32(1, 17, 3, 19, 5, 21, 7, 23, 9, 25, 11, 27, 13, 29, 15, 31);
};
inline void mul_hilo(__m512i a, __m512i m, __m512i m_odd, const HiLoIndex& ix, __m512i& hi, __m512i& lo) {
  const __m512i even = _mm512_mul_epu32(a, m);                                            // lanes 0, 2, ...
  const __m512i odd = _mm512_mul_epu32(_mm512_shuffle_epi32(a, _MM_PERM_CDAB), m_odd);  // lanes 1, 3, ...
  lo = _mm512_permutex2var_epi32(even, ix.lo, odd);
  hi = _mm512_permutex2var_epi32(even, ix.hi, odd);
}

// The Philox state of 16 counters: x[w] holds word w of the 16 blocks.
struct Lanes16 {
  __m512i x[4];
};

// The counters {lo32(c), hi32(c), 0, 0} for c = c0 + lane.
inline Lanes16 counters16(uint64_t c0) {
  const __m512i iota = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  const __m512i base_lo = _mm512_set1_epi32((int)(uint32_t)c0), hi = _mm512_set1_epi32((int)(uint32_t)(c0 >> 32));
  Lanes16 s;
  s.x[0] = _mm512_add_epi32(base_lo, iota);
  // carry into the high word where the low word wrapped
  s.x[1] = _mm512_mask_add_epi32(hi, _mm512_cmplt_epu32_mask(s.x[0], base_lo), hi, _mm512_set1_epi32(1));
  s.x[2] = _mm512_setzero_si512();
  s.x[3] = _mm512_setzero_si512();
  return s;
}

// One Philox round with round keys k0, k1: x0' = hi(x2 m1) ^ x1 ^ k0, x1' = lo(x2 m1), x2' = hi(x0 m0) ^ x3 ^ k1,
// x3' = lo(x0 m0).
inline void round16(Lanes16& s, const __m512i m[4], const HiLoIndex& ix, __m512i k0, __m512i k1) {
  __m512i hi0, lo0, hi1, lo1;
  mul_hilo(s.x[0], m[0], m[1], ix, hi0, lo0);
  mul_hilo(s.x[2], m[2], m[3], ix, hi1, lo1);
  s.x[0] = _mm512_ternarylogic_epi32(hi1, s.x[1], k0, 0x96);  // three-way xor
  s.x[1] = lo1;
  s.x[2] = _mm512_ternarylogic_epi32(hi0, s.x[3], k1, 0x96);
  s.x[3] = lo0;
}

// 4 x 16 words -> 16 blocks of 4 consecutive words at o.
inline void store16(const Lanes16& s, uint32_t* o) {
  const __m512i t01lo = _mm512_unpacklo_epi32(s.x[0], s.x[1]), t01hi = _mm512_unpackhi_epi32(s.x[0], s.x[1]);
  const __m512i t23lo = _mm512_unpacklo_epi32(s.x[2], s.x[3]), t23hi = _mm512_unpackhi_epi32(s.x[2], s.x[3]);
  const __m512i r0 = _mm512_unpacklo_epi64(t01lo, t23lo);  // blocks 0, 4, 8, 12
  const __m512i r1 = _mm512_unpackhi_epi64(t01lo, t23lo);  // blocks 1, 5, 9, 13
  const __m512i r2 = _mm512_unpacklo_epi64(t01hi, t23hi);  // blocks 2, 6, 10, 14
  const __m512i r3 = _mm512_unpackhi_epi64(t01hi, t23hi);  // blocks 3, 7, 11, 15
  const __m512i a = _mm512_shuffle_i32x4(r0, r1, 0x44), b = _mm512_shuffle_i32x4(r2, r3, 0x44);
  const __m512i c = _mm512_shuffle_i32x4(r0, r1, 0xEE), d = _mm512_shuffle_i32x4(r2, r3, 0xEE);
  _mm512_storeu_si512(o, _mm512_shuffle_i32x4(a, b, 0x88));
  _mm512_storeu_si512(o + 16, _mm512_shuffle_i32x4(a, b, 0xDD));
  _mm512_storeu_si512(o + 32, _mm512_shuffle_i32x4(c, d, 0x88));
  _mm512_storeu_si512(o + 48, _mm512_shuffle_i32x4(c, d, 0xDD));
}

}  // namespace

// out[4 b + i] = word i of philox(key = seed, ctr = {lo32(c), hi32(c), 0, 0}), c = counter0 + b, for b < 16 n16.
// Groups of 16 counters go two at a time: the ten rounds of one group are a chain of dependent multiplies, and a
// second independent chain beside it keeps the multipliers busy (1.49 -> 1.76 G words/s against one group at a time
// on the Intel host; bench_tensor_ops BM_philox_blocks).
void philox4x32_blocks_avx512(uint64_t seed, uint64_t counter0, int64_t n16, uint32_t* out) {
  const __m512i m0 = _mm512_set1_epi32((int)kPhiloxM0), m1 = _mm512_set1_epi32((int)kPhiloxM1);
  const __m512i m[4] = {m0, _mm512_shuffle_epi32(m0, _MM_PERM_CDAB), m1, _mm512_shuffle_epi32(m1, _MM_PERM_CDAB)};
  const HiLoIndex ix;
  __m512i k0[10], k1[10];  // the round keys
  uint32_t r0 = (uint32_t)seed, r1 = (uint32_t)(seed >> 32);
  for (int r = 0; r < 10; ++r) {
    if (r > 0) {
      r0 += kPhiloxW0;
      r1 += kPhiloxW1;
    }
    k0[r] = _mm512_set1_epi32((int)r0);
    k1[r] = _mm512_set1_epi32((int)r1);
  }
  int64_t g = 0;
  for (; g + 2 <= n16; g += 2) {
    Lanes16 a = counters16(counter0 + 16 * (uint64_t)g), b = counters16(counter0 + 16 * (uint64_t)(g + 1));
    for (int r = 0; r < 10; ++r) {
      round16(a, m, ix, k0[r], k1[r]);
      round16(b, m, ix, k0[r], k1[r]);
    }
    store16(a, out + 64 * g);
    store16(b, out + 64 * (g + 1));
  }
  if (g < n16) {
    Lanes16 a = counters16(counter0 + 16 * (uint64_t)g);
    for (int r = 0; r < 10; ++r) round16(a, m, ix, k0[r], k1[r]);
    store16(a, out + 64 * g);
  }
}

}  // namespace t2m::rng_detail
