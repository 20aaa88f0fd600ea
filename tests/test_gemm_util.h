// test_gemm_util.h — shared by the GEMM tests: run a check once per float micro-kernel this CPU has; one product
// of the tests that compare the GEMM's internal modes bit for bit (pack depth, A read in place).
#pragma once
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "tensor/gemm.h"
#include "tensor/tensor.h"

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

// A product of the mode-equivalence tests, with its epilogue: 0 beta = 0; 1 alpha 0.75 and beta 0.5; 2 bias; 3 bias
// and ReLU; 4 C in column segments; 5 A and C in column segments; 6 a streamed C (gemm_stream).
struct GemmCase {
  int64_t M, N, K;
  int epilogue;
};

// C of case c under the GEMM's current modes, kernel and thread count (inputs drawn from a seed of the case): A's
// rows with lda_pad spare columns; *streamed, when given, says whether a case 6 streamed. Segments are 20 columns
// with gaps of 3 (tiles straddle them).
inline std::vector<float> run_gemm_case(const GemmCase& c, bool ta, bool tb, int64_t lda_pad = 0,
                                        bool* streamed = nullptr) {
  std::mt19937 rng(uint32_t(c.M * 31 + c.N * 7 + c.K + c.epilogue));
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  const int64_t len = 20, stride = len + 3, a_cols = ta ? c.M : c.K;
  const bool a_segments = c.epilogue == 5;
  const int64_t lda = a_segments ? (a_cols + len - 1) / len * stride : a_cols + lda_pad, ldb = tb ? c.K : c.N;
  std::vector<float> A(size_t((ta ? c.K : c.M) * lda)), B(size_t(c.K * c.N)), bias(size_t(c.N));
  for (auto& v : A) v = u(rng);
  for (auto& v : B) v = u(rng);
  for (auto& v : bias) v = u(rng);
  if (c.epilogue == 4 || a_segments) {
    const int64_t segs = (c.N + len - 1) / len;
    std::vector<float> C(size_t(c.M * segs * stride), 0.25f);
    t2m::gemm_segmented(ta, tb, c.M, c.N, c.K, 1.0f, A.data(), lda,
                        a_segments ? t2m::GemmColumns{len, stride} : t2m::GemmColumns{}, B.data(), ldb, {}, 0.5f,
                        C.data(), segs * stride, {len, stride});
    return C;
  }
  std::vector<float> C(size_t(c.M * c.N));
  for (auto& v : C) v = u(rng);
  if (c.epilogue == 6) {  // C in a Tensor's 64-byte aligned storage, so that it streams where it is at least the L2
    t2m::Tensor c64 = t2m::Tensor::zeros({c.M, c.N});
    const bool s =
        t2m::gemm_stream(ta, tb, c.M, c.N, c.K, 1.0f, A.data(), lda, B.data(), ldb, c64.data<float>(), c.N);
    if (streamed) *streamed = s;
    std::memcpy(C.data(), c64.data<float>(), C.size() * sizeof(float));
  } else if (c.epilogue == 3) {
    t2m::gemm_bias_relu(ta, tb, c.M, c.N, c.K, 1.0f, A.data(), lda, B.data(), ldb, bias.data(), C.data(), c.N);
  } else if (c.epilogue == 2) {
    t2m::gemm_bias(ta, tb, c.M, c.N, c.K, 0.5f, A.data(), lda, B.data(), ldb, bias.data(), C.data(), c.N);
  } else {
    t2m::gemm(ta, tb, c.M, c.N, c.K, c.epilogue ? 0.75f : 1.0f, A.data(), lda, B.data(), ldb,
              c.epilogue ? 0.5f : 0.0f, C.data(), c.N);
  }
  return C;
}

inline bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}
