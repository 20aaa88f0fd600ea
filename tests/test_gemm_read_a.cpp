// test_gemm_read_a.cpp — reading op(A) = A in place (t2m::gemm_force_read_a) instead of packing it changes no bit
// of any float result: one and several row blocks with short last panels (M % 12 = 4, 5, 8), few and many columns,
// K across 1-3 kernel blocks with a short last one, pack depths 1 and 2, alpha / beta / bias / ReLU epilogues, C
// in column segments, both micro-kernels, 1 and 2 threads (both thread splits); the in-place path runs for plain
// A only (not for A^T, A in segments or a streamed C); bad modes are rejected.
#include <gtest/gtest.h>

#include <vector>

#include "tensor/gemm.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"
#include "test_gemm_util.h"

namespace {

TEST(GemmReadA, InPlaceChangesNoBit) {
  const int saved = t2m::get_num_threads();
  // Rows: one row block with a short panel (44, 100: M % 12 = 8, 4), several (389: 5; 530: the column split; 700
  // with 90 columns: the row split). K = 1100 spans three blocks (512, 512, 76). C of 900 x 600 floats (2.2 MB) is
  // large enough to stream where the L2 is 2 MB or less.
  const GemmCase cases[] = {{100, 70, 1100, 0}, {44, 96, 600, 1},   {389, 300, 600, 2}, {530, 800, 1100, 0},
                            {700, 90, 1300, 2}, {389, 130, 700, 3}, {400, 100, 300, 4}, {400, 100, 300, 5},
                            {900, 600, 256, 6}, {250, 1500, 200, 1}};
  for_each_kernel([&] {
    for (const GemmCase& c : cases)
      for (int t = 0; t < 4; ++t) {
        const bool ta = t & 1, tb = t & 2;
        for (int threads : {1, 2})
          for (int depth : {1, 2}) {
            t2m::set_num_threads(threads);
            t2m::gemm_force_pack_depth(depth);
            t2m::gemm_force_read_a("packed");
            const std::vector<float> ref = run_gemm_case(c, ta, tb, 3);
            const int64_t before = t2m::gemm_force_read_a("in_place");
            bool streamed = false;
            EXPECT_TRUE(same_bits(run_gemm_case(c, ta, tb, 3, &streamed), ref))
                << "M=" << c.M << " N=" << c.N << " K=" << c.K << " epilogue=" << c.epilogue << " ta=" << ta
                << " tb=" << tb << " threads=" << threads << " depth=" << depth
                << " kernel=" << t2m::gemm_kernel_name();
            // In place exactly where A is plain (not transposed, not in segments) and C is not streamed.
            const bool plain = !ta && c.epilogue != 5;
            const int64_t ran = t2m::gemm_force_read_a("auto") - before;
            EXPECT_EQ(ran > 0, plain && !streamed) << "M=" << c.M << " epilogue=" << c.epilogue << " ta=" << ta;
            EXPECT_TRUE(same_bits(run_gemm_case(c, ta, tb, 3), ref)) << "auto, M=" << c.M << " N=" << c.N;
          }
      }
  });
  t2m::gemm_force_pack_depth(0);
  t2m::gemm_force_read_a("auto");
  t2m::set_num_threads(saved);
}

// The automatic choice: in place for several row blocks with few columns per thread, packed otherwise.
TEST(GemmReadA, AutomaticChoice) {
  const int saved = t2m::get_num_threads();
  t2m::set_num_threads(1);
  t2m::gemm_force_read_a("auto");
  auto ran = [](int64_t M, int64_t N, int64_t lda = 64) {
    std::vector<float> A(size_t(M * lda), 0.5f), B(size_t(64 * N), 0.25f), C(size_t(M * N));
    const int64_t before = t2m::gemm_force_read_a("auto");
    t2m::gemm(false, false, M, N, 64, 1.0f, A.data(), lda, B.data(), N, 0.0f, C.data(), N);
    return t2m::gemm_force_read_a("auto") > before;
  };
  EXPECT_TRUE(ran(400, 256));
  EXPECT_FALSE(ran(400, 2048));  // many columns: each packed A panel meets 64 B panels
  EXPECT_FALSE(ran(100, 256));   // one row block
  EXPECT_FALSE(ran(400, 256, 1024));  // rows 4 KB apart: all in one L1 set
  EXPECT_FALSE(ran(400, 256, 3072));
  EXPECT_TRUE(ran(400, 256, 1040));
  EXPECT_TRUE(ran(400, 256, 1536));  // 6 KB apart: two sets
  t2m::set_num_threads(saved);
}

TEST(GemmReadA, BadModes) {
  EXPECT_THROW(t2m::gemm_force_read_a("rows"), t2m::Error);
  EXPECT_THROW(t2m::gemm_force_read_a(nullptr), t2m::Error);
  EXPECT_NO_THROW(t2m::gemm_force_read_a("auto"));
}

}  // namespace
