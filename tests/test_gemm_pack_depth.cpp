// test_gemm_pack_depth.cpp — the packed K depth (t2m::gemm_force_pack_depth: how many of the micro-kernel's K
// blocks are packed at once) changes no bit of any float result: K across 1-3 blocks with a short last one, edge
// and short row panels, alpha / beta / bias / ReLU epilogues, C in segments, both micro-kernels, 1 and 2 threads
// (both thread splits, and the column split's shared A from 512 rows); bad depths rejected.
#include <gtest/gtest.h>

#include <vector>

#include "tensor/gemm.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"
#include "test_gemm_util.h"

namespace {

TEST(GemmPackDepth, DepthChangesNoBit) {
  const int saved = t2m::get_num_threads();
  // K = 1100: blocks of 512, 512 and 76; 1500 (two full blocks and a short one), 600, 300 (one block). Rows:
  // short last panels (M % 12 = 4 or 8), 530 (column split with shared A), 700x90 (row split), tiny.
  const GemmCase cases[] = {{100, 70, 1100, 0}, {52, 96, 1500, 1}, {200, 300, 600, 2}, {44, 64, 1100, 3},
                            {530, 800, 1100, 0}, {700, 90, 1300, 2}, {40, 50, 300, 4},  {100, 130, 1100, 4},
                            {20, 40, 1030, 3}};
  for_each_kernel([&] {
    for (const GemmCase& c : cases)
      for (int t = 0; t < 4; ++t) {
        const bool ta = t & 1, tb = t & 2;
        for (int threads : {1, 2}) {
          t2m::set_num_threads(threads);
          t2m::gemm_force_pack_depth(1);
          const std::vector<float> ref = run_gemm_case(c, ta, tb);
          for (int depth : {2, 3}) {
            t2m::gemm_force_pack_depth(depth);
            EXPECT_TRUE(same_bits(run_gemm_case(c, ta, tb), ref))
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
