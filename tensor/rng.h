// rng.h — counter-based random numbers (Philox4x32-10). Element i of a draw depends only on (seed, offset + i),
// so the numbers are identical for any thread count and any chunking.
#pragma once
#include <cstdint>
#include <vector>

#include "tensor/tensor.h"

namespace t2m {

class Generator {
 public:
  explicit Generator(uint64_t seed = 0) : seed_(seed) {}
  uint64_t seed() const { return seed_; }
  uint64_t offset() const { return offset_; }           // counters consumed so far (the state to checkpoint)
  void set_state(uint64_t seed, uint64_t offset) { seed_ = seed; offset_ = offset; }
  // Reserves n counters and returns the first (advances the state).
  uint64_t advance(uint64_t n) { uint64_t o = offset_; offset_ += n; return o; }

 private:
  uint64_t seed_ = 0;
  uint64_t offset_ = 0;
};

// Philox4x32-10 block: four 32-bit outputs for (key = seed, counter).
void philox4x32(uint64_t seed, uint64_t counter, uint32_t out[4]);
// The raw Philox4x32-10 bijection on a full 128-bit counter and 64-bit key (philox4x32 above uses
// ctr = {lo32(counter), hi32(counter), 0, 0}, key = {lo32(seed), hi32(seed)}). For known-answer tests.
void philox4x32_block(const uint32_t ctr[4], const uint32_t key[2], uint32_t out[4]);
// Blocks for counters counter0 .. counter0 + nblocks - 1: out[4 b + i] = philox4x32(seed, counter0 + b)[i]
// (4 * nblocks words). 16 counters per step with AVX-512 where the CPU has it, the scalar block otherwise.
void philox4x32_blocks(uint64_t seed, uint64_t counter0, int64_t nblocks, uint32_t* out);
// Counters per draw: f32 uniform/normal/bernoulli use one counter per 4 values, f64 uniform/normal and randint
// one per 2 values, randperm(n) one per 2 swaps; the Generator advances by that many.

Tensor rand_uniform(const Shape& shape, Generator& gen, double lo = 0.0, double hi = 1.0, DType dtype = DType::f32);
Tensor rand_normal(const Shape& shape, Generator& gen, double mean = 0.0, double std = 1.0, DType dtype = DType::f32);
Tensor rand_bernoulli(const Shape& shape, Generator& gen, double p, DType dtype = DType::f32);  // values 0/1
std::vector<int64_t> randperm(int64_t n, Generator& gen);
Tensor randint(const Shape& shape, Generator& gen, int64_t lo, int64_t hi);  // int64 in [lo, hi)

}  // namespace t2m
