// rng_philox.h — internal to tensor/rng*.cpp: the constants of Philox4x32-10 (Salmon et al. 2011), shared by the
// scalar rounds (rng.cpp) and the 16-lane AVX-512 rounds (rng_avx512.cpp), which must give the same words.
#pragma once
#include <cstdint>

namespace t2m::rng_detail {

constexpr uint32_t kPhiloxM0 = 0xD2511F53u, kPhiloxM1 = 0xCD9E8D57u;  // round multipliers
constexpr uint32_t kPhiloxW0 = 0x9E3779B9u, kPhiloxW1 = 0xBB67AE85u;  // Weyl key increments

}  // namespace t2m::rng_detail
