// rng_avx512.cpp — Philox4x32-10 on 16 counters at once (AVX-512F; compiled with AVX-512 flags, called only
// when the CPU has it, see philox4x32_blocks in rng.cpp). Same words as the scalar philox4x32, bit for bit.
#include <immintrin.h>

#include <cstdint>

// GCC 12's AVX-512 headers build shift/unpack results on a self-initialised "undefined" vector, which
// -Wmaybe-uninitialized reports once inlined here (a known false positive).
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

namespace t2m::rng_detail {

namespace {

// hi and lo 32-bit halves of the 16 lane products a * m.
inline void mul_hilo(__m512i a, __m512i m, __m512i& hi, __m512i& lo) {
  const __m512i even = _mm512_mul_epu32(a, m);                                          // lanes 0, 2, ...
  const __m512i odd = _mm512_mul_epu32(_mm512_srli_epi64(a, 32), _mm512_srli_epi64(m, 32));  // lanes 1, 3, ...
  lo = _mm512_mask_blend_epi32(0xAAAA, even, _mm512_slli_epi64(odd, 32));
  hi = _mm512_mask_blend_epi32(0xAAAA, _mm512_srli_epi64(even, 32), odd);
}

}  // namespace

// out[4 b + i] = word i of philox(key = seed, ctr = {lo32(c), hi32(c), 0, 0}), c = counter0 + b, for b < 16 n16.
void philox4x32_blocks_avx512(uint64_t seed, uint64_t counter0, int64_t n16, uint32_t* out) {
  const __m512i m0 = _mm512_set1_epi32((int)0xD2511F53u), m1 = _mm512_set1_epi32((int)0xCD9E8D57u);
  const __m512i iota = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  for (int64_t g = 0; g < n16; ++g) {
    const uint64_t c0 = counter0 + 16 * (uint64_t)g;
    const __m512i base_lo = _mm512_set1_epi32((int)(uint32_t)c0);
    __m512i x0 = _mm512_add_epi32(base_lo, iota);
    // carry into the high word where the low word wrapped
    __m512i x1 = _mm512_mask_add_epi32(_mm512_set1_epi32((int)(uint32_t)(c0 >> 32)),
                                       _mm512_cmplt_epu32_mask(x0, base_lo),
                                       _mm512_set1_epi32((int)(uint32_t)(c0 >> 32)), _mm512_set1_epi32(1));
    __m512i x2 = _mm512_setzero_si512(), x3 = _mm512_setzero_si512();
    uint32_t k0 = (uint32_t)seed, k1 = (uint32_t)(seed >> 32);
    for (int r = 0; r < 10; ++r) {
      if (r > 0) {
        k0 += 0x9E3779B9u;
        k1 += 0xBB67AE85u;
      }
      __m512i hi0, lo0, hi1, lo1;
      mul_hilo(x0, m0, hi0, lo0);
      mul_hilo(x2, m1, hi1, lo1);
      const __m512i n0 = _mm512_xor_si512(_mm512_xor_si512(hi1, x1), _mm512_set1_epi32((int)k0));
      const __m512i n2 = _mm512_xor_si512(_mm512_xor_si512(hi0, x3), _mm512_set1_epi32((int)k1));
      x0 = n0;
      x1 = lo1;
      x2 = n2;
      x3 = lo0;
    }
    // 4 x 16 words -> 16 blocks of 4 consecutive words
    const __m512i t01lo = _mm512_unpacklo_epi32(x0, x1), t01hi = _mm512_unpackhi_epi32(x0, x1);
    const __m512i t23lo = _mm512_unpacklo_epi32(x2, x3), t23hi = _mm512_unpackhi_epi32(x2, x3);
    const __m512i r0 = _mm512_unpacklo_epi64(t01lo, t23lo);  // blocks 0, 4, 8, 12
    const __m512i r1 = _mm512_unpackhi_epi64(t01lo, t23lo);  // blocks 1, 5, 9, 13
    const __m512i r2 = _mm512_unpacklo_epi64(t01hi, t23hi);  // blocks 2, 6, 10, 14
    const __m512i r3 = _mm512_unpackhi_epi64(t01hi, t23hi);  // blocks 3, 7, 11, 15
    const __m512i a = _mm512_shuffle_i32x4(r0, r1, 0x44), b = _mm512_shuffle_i32x4(r2, r3, 0x44);
    const __m512i c = _mm512_shuffle_i32x4(r0, r1, 0xEE), d = _mm512_shuffle_i32x4(r2, r3, 0xEE);
    uint32_t* o = out + 64 * g;
    _mm512_storeu_si512(o, _mm512_shuffle_i32x4(a, b, 0x88));
    _mm512_storeu_si512(o + 16, _mm512_shuffle_i32x4(a, b, 0xDD));
    _mm512_storeu_si512(o + 32, _mm512_shuffle_i32x4(c, d, 0x88));
    _mm512_storeu_si512(o + 48, _mm512_shuffle_i32x4(c, d, 0xDD));
  }
}

}  // namespace t2m::rng_detail
