// gelu_tanh_kernels.h — INTERNAL to tensor/fused/gelu_tanh*.cpp: the elementwise loops of gelu_tanh.h, included by
// gelu_tanh.cpp (baseline AVX2 build) and gelu_tanh_avx512.cpp (AVX-512 flags: twice the lanes, the same
// arithmetic per element, so the same bits). Anonymous namespace: each including file compiles its own copy.
// With u = s (x + a x^3), t = tanh(u): dy/dx = 0.5 (1 + t) + 0.5 x (1 - t^2) s (1 + 3 a x^2).
#pragma once
#include <cstdint>

#include "tensor/fused/fast_exp.h"

namespace t2m::fused {
namespace {

constexpr double kSqrt2OverPi = 0.79788456080286535588;
constexpr double kGeluA = 0.044715;

// One thread's contiguous chunk; a plain loop (no OpenMP construct) so that the float version vectorises.
template <typename T>
void gelu_forward_chunk(T* out, const T* inp, int64_t n) {
  const T s = (T)kSqrt2OverPi, a = (T)kGeluA;
#pragma omp simd
  for (int64_t i = 0; i < n; ++i) {
    const T x = inp[i];
    const T t = ftanh(s * (x + a * x * x * x));
    out[i] = (T)0.5 * x * ((T)1 + t);
  }
}

template <typename T>
void gelu_backward_chunk(T* dinp, const T* dout, const T* inp, int64_t n) {
  const T s = (T)kSqrt2OverPi, a = (T)kGeluA;
#pragma omp simd
  for (int64_t i = 0; i < n; ++i) {
    const T x = inp[i];
    const T x2 = x * x;
    const T t = ftanh(s * (x + a * x2 * x));
    const T d = (T)0.5 * ((T)1 + t) + (T)0.5 * x * ((T)1 - t * t) * s * ((T)1 + (T)3 * a * x2);
    dinp[i] = dout[i] * d;
  }
}

}  // namespace

// The loops above compiled with AVX-512 (gelu_tanh_avx512.cpp); call only where use_avx512_kernels().
template <typename T>
void gelu_forward_chunk_avx512(T* out, const T* inp, int64_t n);
template <typename T>
void gelu_backward_chunk_avx512(T* dinp, const T* dout, const T* inp, int64_t n);

}  // namespace t2m::fused
