// fast_exp.h — INTERNAL to tensor/fused/: exp and tanh that the compiler can vectorise (float), and the libm
// versions for double (double is the precision reference used by finite-difference checks).
//
// float exp: range reduction x = n*ln2 + r with |r| <= ln2/2, Taylor polynomial of degree 7 for e^r (truncation
// error < 1e-8 relative), scale by 2^n through the exponent bits. Inputs are clamped to [-87.3, 88.3], so the
// result never overflows and very negative inputs give a tiny positive number (~1e-38) instead of 0.
// Max relative error measured against std::exp: a few ulp. NaN inputs are not propagated (clamped).
// tanh(u) = 1 - 2 / (e^{2u} + 1), absolute error ~1e-7 (relative error is larger only for |u| < 1e-3).
#pragma once
#include <bit>
#include <cmath>
#include <cstdint>

namespace t2m::fused {

inline float exp_approx(float x) {
  constexpr float kLog2e = 1.44269504088896341f;
  constexpr float kLn2Hi = 0.693145751953125f;       // ln2 with the low 12 bits of the mantissa cleared
  constexpr float kLn2Lo = 1.428606765330187045e-6f;  // ln2 - kLn2Hi
  constexpr float kRound = 12582912.0f;               // 1.5 * 2^23: adding it rounds to an integer
  x = x < -87.3f ? -87.3f : x;
  x = x > 88.3f ? 88.3f : x;
  float t = x * kLog2e + kRound;
  float n = t - kRound;
  int32_t ni = std::bit_cast<int32_t>(t) - std::bit_cast<int32_t>(kRound);
  float r = x - n * kLn2Hi;
  r = r - n * kLn2Lo;
  // e^r = sum_{i<=7} r^i / i!  (Horner)
  float p = 1.0f / 5040.0f;
  p = p * r + 1.0f / 720.0f;
  p = p * r + 1.0f / 120.0f;
  p = p * r + 1.0f / 24.0f;
  p = p * r + 1.0f / 6.0f;
  p = p * r + 0.5f;
  p = p * r + 1.0f;
  p = p * r + 1.0f;
  float scale = std::bit_cast<float>((ni + 127) << 23);
  return p * scale;
}

inline float tanh_approx(float u) {
  float e = exp_approx(2.0f * u);
  return 1.0f - 2.0f / (e + 1.0f);
}

// Dispatch by scalar type: float uses the vectorisable approximations, double the exact libm functions.
inline float fexp(float x) { return exp_approx(x); }
inline double fexp(double x) { return std::exp(x); }
inline float ftanh(float x) { return tanh_approx(x); }
inline double ftanh(double x) { return std::tanh(x); }

}  // namespace t2m::fused
