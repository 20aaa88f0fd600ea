// test_rng_blocks.cpp — philox4x32_blocks (16 counters per AVX-512 step where the CPU has it) against the scalar
// philox4x32 word for word: block counts around the 16-lane width, a counter range that carries from the low
// into the high 32-bit word, 64-bit seeds; and rand_uniform/rand_bernoulli values equal to the scalar layout.
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "tensor/rng.h"

using namespace t2m;

namespace {

std::vector<uint32_t> scalar_blocks(uint64_t seed, uint64_t c0, int64_t n) {
  std::vector<uint32_t> out(4 * n);
  for (int64_t b = 0; b < n; ++b) philox4x32(seed, c0 + (uint64_t)b, out.data() + 4 * b);
  return out;
}

TEST(RngBlocks, MatchScalarPhiloxWordForWord) {
  const uint64_t seeds[] = {0, 1234, 0x299f31d0a4093822ull, ~0ull};
  const uint64_t starts[] = {0, 7, 0xFFFFFFF8ull, 0x1FFFFFFF0ull, ~0ull - 40};  // low-word carry at 2^32, 2^33
  for (uint64_t seed : seeds)
    for (uint64_t c0 : starts)
      for (int64_t n : {0, 1, 15, 16, 17, 31, 32, 33, 48, 64, 65, 100}) {
        std::vector<uint32_t> got(4 * n + 4, 0xDEADBEEFu);
        philox4x32_blocks(seed, c0, n, got.data());
        const auto want = scalar_blocks(seed, c0, n);
        for (int64_t i = 0; i < 4 * n; ++i)
          ASSERT_EQ(got[i], want[i]) << "seed " << seed << " c0 " << c0 << " n " << n << " word " << i;
        for (int64_t i = 4 * n; i < 4 * n + 4; ++i) EXPECT_EQ(got[i], 0xDEADBEEFu) << "wrote past the end";
      }
}

// rand_uniform f32: value i = u24(word i % 4 of block offset + i / 4) scaled to [lo, hi) (rng.h layout).
TEST(RngBlocks, UniformDrawFollowsTheCounterLayout) {
  Generator gen(99);
  gen.advance(5);
  const int64_t n = 1003;
  const Tensor t = rand_uniform({n}, gen, 0.0, 1.0);
  const auto words = scalar_blocks(99, 5, (n + 3) / 4);
  for (int64_t i = 0; i < n; ++i)
    ASSERT_EQ(t.data<float>()[i], (float)(words[i] >> 8) * (1.0f / 16777216.0f)) << i;
  EXPECT_EQ(gen.offset(), 5u + (uint64_t)(n + 3) / 4);
}

}  // namespace
