// cpu_features.h — what this CPU runs, asked once (cpuid): the AVX-512 subset the *_avx512.cpp files are compiled
// for (avx512f/bw/dq/vl) and the x86-64-v3 baseline (avx2 + fma). Kernels with two builds call their AVX-512 build
// when use_avx512_kernels(); force_baseline_isa(true) makes them take the baseline build even on an AVX-512 CPU
// (tests compare the two builds). The GEMM has its own switch (gemm_force_kernel, tensor/gemm.h).
#pragma once

namespace t2m {

bool cpu_has_avx512();
bool cpu_has_avx2();
bool use_avx512_kernels();  // cpu_has_avx512() and not forced to the baseline
void force_baseline_isa(bool on);

}  // namespace t2m
