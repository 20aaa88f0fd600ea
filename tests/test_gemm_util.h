// test_gemm_util.h — shared by the GEMM tests: run a check once per float micro-kernel this CPU has.
#pragma once
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "tensor/gemm.h"

// Runs fn once per available kernel (avx512 only where the CPU has it), restoring "auto" afterwards.
template <typename F>
void for_each_kernel(F fn) {
  std::vector<std::string> kernels = {"avx2"};
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq") &&
      __builtin_cpu_supports("avx512vl"))
    kernels.push_back("avx512");
  for (const auto& k : kernels) {
    t2m::gemm_force_kernel(k.c_str());
    EXPECT_STREQ(t2m::gemm_kernel_name(), k.c_str());
    fn();
  }
  t2m::gemm_force_kernel("auto");
}
