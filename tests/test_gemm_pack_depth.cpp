// test_gemm_pack_depth.cpp — the packed K depth (t2m::gemm_force_pack_depth: how many of the micro-kernel's K
// blocks are packed at once) changes no bit of any float result: K across 1-3 blocks with a short last one, edge
// and short row panels, alpha / beta / bias / ReLU epilogues, C in segments, both micro-kernels, 1 and 2 threads
// (both thread splits, and the column split's shared A from 512 rows); bad depths rejected.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "tensor/gemm.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"
#include "test_gemm_util.h"

namespace {

struct Case {
  int64_t M, N, K;
  int epilogue;  // 0: beta = 0, 1: alpha 0.75 and beta 0.5, 2: bias, 3: bias and ReLU, 4: C in column segments
};

// C for one case at the current pack depth and thread count.
std::vector<float> run_case(const Case& c, bool ta, bool tb) {
  std::mt19937 rng(uint32_t(c.M * 31 + c.N * 7 + c.K + c.epilogue));
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> A(size_t(c.M * c.K)), B(size_t(c.K * c.N)), bias(size_t(c.N));
  for (auto& v : A) v = u(rng);
  for (auto& v : B) v = u(rng);
  for (auto& v : bias) v = u(rng);
  const int64_t lda = ta ? c.M : c.K, ldb = tb ? c.K : c.N;
  if (c.epilogue == 4) {  // C's columns in segments of 20 (tiles straddle them), gaps of 3 between
    const int64_t len = 20, stride = len + 3, segs = (c.N + len - 1) / len;
    std::vector<float> C(size_t(c.M * segs * stride), 0.25f);
    t2m::gemm_segmented(ta, tb, c.M, c.N, c.K, 1.0f, A.data(), lda, {}, B.data(), ldb, {}, 0.5f, C.data(),
                        segs * stride, {len, stride});
    return C;
  }
  std::vector<float> C(size_t(c.M * c.N));
  for (auto& v : C) v = u(rng);
  if (c.epilogue == 3)
    t2m::gemm_bias_relu(ta, tb, c.M, c.N, c.K, 1.0f, A.data(), lda, B.data(), ldb, bias.data(), C.data(), c.N);
  else if (c.epilogue == 2)
    t2m::gemm_bias(ta, tb, c.M, c.N, c.K, 0.5f, A.data(), lda, B.data(), ldb, bias.data(), C.data(), c.N);
  else
    t2m::gemm(ta, tb, c.M, c.N, c.K, c.epilogue ? 0.75f : 1.0f, A.data(), lda, B.data(), ldb,
              c.epilogue ? 0.5f : 0.0f, C.data(), c.N);
  return C;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

TEST(GemmPackDepth, DepthChangesNoBit) {
  const int saved = t2m::get_num_threads();
  // K = 1100: blocks of 512, 512 and 76; 1500 (two full blocks and a short one), 600, 300 (one block). Rows:
  // short last panels (M % 12 = 4 or 8), 530 (column split with shared A), 700x90 (row split), tiny.
  const Case cases[] = {{100, 70, 1100, 0}, {52, 96, 1500, 1}, {200, 300, 600, 2}, {44, 64, 1100, 3},
                        {530, 800, 1100, 0}, {700, 90, 1300, 2}, {40, 50, 300, 4},  {100, 130, 1100, 4},
                        {20, 40, 1030, 3}};
  for_each_kernel([&] {
    for (const Case& c : cases)
      for (int t = 0; t < 4; ++t) {
        const bool ta = t & 1, tb = t & 2;
        for (int threads : {1, 2}) {
          t2m::set_num_threads(threads);
          t2m::gemm_force_pack_depth(1);
          const std::vector<float> ref = run_case(c, ta, tb);
          for (int depth : {2, 3}) {
            t2m::gemm_force_pack_depth(depth);
            EXPECT_TRUE(same_bits(run_case(c, ta, tb), ref))
                << "M=" << c.M << " N=" << c.N << " K=" << c.K << " epilogue=" << c.epilogue << " ta=" << ta
                << " tb=" << tb << " threads=" << threads << " depth=" << depth << " kernel=" << t2m::gemm_kernel_name();
          }
        }
      }
  });
  t2m::gemm_force_pack_depth(0);
  t2m::set_num_threads(saved);
}

TEST(GemmPackDepth, AutomaticChoiceAndBadDepths) {
  const int automatic = t2m::gemm_force_pack_depth(0);
  EXPECT_TRUE(automatic == 1 || automatic == 2);
  EXPECT_THROW(t2m::gemm_force_pack_depth(-1), t2m::Error);
  EXPECT_THROW(t2m::gemm_force_pack_depth(9), t2m::Error);
}

}  // namespace
