// test_gemm_read_a.cpp — reading op(A) = A in place (t2m::gemm_force_read_a) instead of packing it changes no bit
// of any float result: one and several row blocks with short last panels (M % 12 = 4, 5, 8), few and many columns,
// K across 1-3 kernel blocks with a short last one, pack depths 1 and 2, alpha / beta / bias / ReLU epilogues, C
// in column segments, both micro-kernels, 1 and 2 threads (both thread splits); the in-place path runs for plain
// A only (not for A^T, A in segments or a streamed C); bad modes are rejected.
#include <gtest/gtest.h>

#include <cstdint>
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
  int epilogue;  // 0: beta = 0, 1: alpha 0.75 and beta 0.5, 2: bias, 3: bias and ReLU, 4: C in column segments,
                 // 5: A in column segments, 6: streamed C (gemm_stream)
};

bool g_streamed = false;  // whether the last streamed case (epilogue 6) streamed

// C for one case under the current mode, kernel and thread count; lda has 3 spare columns (A's rows are not
// packed back to back).
std::vector<float> run_case(const Case& c, bool ta, bool tb) {
  std::mt19937 rng(uint32_t(c.M * 31 + c.N * 7 + c.K + c.epilogue));
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  const int64_t lda = (ta ? c.M : c.K) + 3, ldb = tb ? c.K : c.N;
  std::vector<float> A(size_t((ta ? c.K : c.M) * lda)), B(size_t(c.K * c.N)), bias(size_t(c.N));
  for (auto& v : A) v = u(rng);
  for (auto& v : B) v = u(rng);
  for (auto& v : bias) v = u(rng);
  if (c.epilogue == 4 || c.epilogue == 5) {  // segments of 20 columns (tiles straddle them), gaps of 3 between
    const int64_t len = 20, stride = len + 3, segs = (c.N + len - 1) / len;
    std::vector<float> C(size_t(c.M * segs * stride), 0.25f);
    const t2m::GemmColumns a_cols = c.epilogue == 5 ? t2m::GemmColumns{len, stride} : t2m::GemmColumns{};
    const int64_t a_stored = ta ? c.M : c.K, a_ld = c.epilogue == 5 ? (a_stored + len - 1) / len * stride : lda;
    std::vector<float> As(size_t((ta ? c.K : c.M) * a_ld));
    for (auto& v : As) v = u(rng);
    t2m::gemm_segmented(ta, tb, c.M, c.N, c.K, 1.0f, As.data(), a_ld, a_cols, B.data(), ldb, {}, 0.5f, C.data(),
                        segs * stride, {len, stride});
    return C;
  }
  std::vector<float> C(size_t(c.M * c.N));
  for (auto& v : C) v = u(rng);
  if (c.epilogue == 6) {  // C 64-byte aligned, so that it streams where it is at least the L2's size
    std::vector<float> buf(C.size() + 16);
    float* c64 = reinterpret_cast<float*>((reinterpret_cast<uintptr_t>(buf.data()) + 63) & ~uintptr_t(63));
    g_streamed = t2m::gemm_stream(ta, tb, c.M, c.N, c.K, 1.0f, A.data(), lda, B.data(), ldb, c64, c.N);
    std::memcpy(C.data(), c64, C.size() * sizeof(float));
  } else if (c.epilogue == 3)
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

TEST(GemmReadA, InPlaceChangesNoBit) {
  const int saved = t2m::get_num_threads();
  // Rows: one row block with a short panel (44, 100: M % 12 = 8, 4), several (389: 5; 530: the column split; 700
  // with 90 columns: the row split). K = 1100 spans three blocks (512, 512, 76). C of 900 x 600 floats (2.2 MB) is
  // large enough to stream where the L2 is 2 MB or less.
  const Case cases[] = {{100, 70, 1100, 0}, {44, 96, 600, 1},   {389, 300, 600, 2}, {530, 800, 1100, 0},
                        {700, 90, 1300, 2}, {389, 130, 700, 3}, {400, 100, 300, 4}, {400, 100, 300, 5},
                        {900, 600, 256, 6}, {250, 1500, 200, 1}};
  for_each_kernel([&] {
    for (const Case& c : cases)
      for (int t = 0; t < 4; ++t) {
        const bool ta = t & 1, tb = t & 2;
        for (int threads : {1, 2})
          for (int depth : {1, 2}) {
            t2m::set_num_threads(threads);
            t2m::gemm_force_pack_depth(depth);
            t2m::gemm_force_read_a("packed");
            const std::vector<float> ref = run_case(c, ta, tb);
            const int64_t before = t2m::gemm_force_read_a("in_place");
            g_streamed = false;
            EXPECT_TRUE(same_bits(run_case(c, ta, tb), ref))
                << "M=" << c.M << " N=" << c.N << " K=" << c.K << " epilogue=" << c.epilogue << " ta=" << ta
                << " tb=" << tb << " threads=" << threads << " depth=" << depth
                << " kernel=" << t2m::gemm_kernel_name();
            // In place exactly where A is plain (not transposed, not in segments) and C is not streamed.
            const bool plain = !ta && c.epilogue != 5;
            const int64_t ran = t2m::gemm_force_read_a("auto") - before;
            EXPECT_EQ(ran > 0, plain && !g_streamed) << "M=" << c.M << " epilogue=" << c.epilogue << " ta=" << ta;
            EXPECT_TRUE(same_bits(run_case(c, ta, tb), ref)) << "auto, M=" << c.M << " N=" << c.N;
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
  auto ran = [](int64_t M, int64_t N) {
    std::vector<float> A(size_t(M * 64), 0.5f), B(size_t(64 * N), 0.25f), C(size_t(M * N));
    const int64_t before = t2m::gemm_force_read_a("auto");
    t2m::gemm(false, false, M, N, 64, 1.0f, A.data(), 64, B.data(), N, 0.0f, C.data(), N);
    return t2m::gemm_force_read_a("auto") > before;
  };
  EXPECT_TRUE(ran(400, 256));
  EXPECT_FALSE(ran(400, 2048));  // many columns: each packed A panel meets 64 B panels
  EXPECT_FALSE(ran(100, 256));   // one row block
  t2m::set_num_threads(saved);
}

TEST(GemmReadA, BadModes) {
  EXPECT_THROW(t2m::gemm_force_read_a("rows"), t2m::Error);
  EXPECT_THROW(t2m::gemm_force_read_a(nullptr), t2m::Error);
  EXPECT_NO_THROW(t2m::gemm_force_read_a("auto"));
}

}  // namespace
