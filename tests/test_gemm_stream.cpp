// test_gemm_stream.cpp — t2m::gemm_stream (C written with non-temporal stores: the weight gradients) gives the
// bits of gemm with beta = 0 whichever path it takes: streamed (C at least the L2's size, K within one kernel block,
// rows 64-byte aligned; full tiles streamed, edge tiles and short row panels plain) or not (misaligned rows, K over
// one block, a small C, double). All four transposes, both micro-kernels, 1 and 2 threads (both thread splits).
// C starts as NaN: beta = 0 never reads it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "tensor/gemm.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"
#include "test_gemm_util.h"

namespace {

using t2m::DType;
using t2m::Tensor;

// Rows of C for a C of at least `bytes` with N columns.
int64_t rows_for(int64_t bytes, int64_t N) { return (bytes / int64_t(sizeof(float)) + N - 1) / N; }

struct Case {
  int64_t M, N, K, ldc_pad, c_offset;  // ldc = N + ldc_pad; C starts c_offset floats into an aligned block
  bool streams;                         // expected on an AVX2 or AVX-512 CPU
};

// gemm_stream against gemm (beta = 0) on the same operands; returns whether gemm_stream streamed.
template <typename T>
bool check_case(const Case& c, bool ta, bool tb) {
  std::mt19937 rng(uint32_t(c.M * 3 + c.N * 5 + c.K * 7 + ta + 2 * tb));
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<T> A(size_t(c.M * c.K)), B(size_t(c.K * c.N));
  for (auto& v : A) v = T(u(rng));
  for (auto& v : B) v = T(u(rng));
  const int64_t lda = ta ? c.M : c.K, ldb = tb ? c.K : c.N, ldc = c.N + c.ldc_pad;
  const DType dt = sizeof(T) == 4 ? DType::f32 : DType::f64;
  // Tensor storage is 64-byte aligned; c_offset shifts C off that alignment.
  Tensor s = Tensor::full({c.M * ldc + c.c_offset}, std::numeric_limits<double>::quiet_NaN(), dt);
  Tensor r = Tensor::full({c.M * ldc + c.c_offset}, std::numeric_limits<double>::quiet_NaN(), dt);
  const bool streamed = t2m::gemm_stream(ta, tb, c.M, c.N, c.K, T(0.5), A.data(), lda, B.data(), ldb,
                                         s.data<T>() + c.c_offset, ldc);
  t2m::gemm(ta, tb, c.M, c.N, c.K, T(0.5), A.data(), lda, B.data(), ldb, T(0), r.data<T>() + c.c_offset, ldc);
  const T* sp = s.data<T>() + c.c_offset;
  const T* rp = r.data<T>() + c.c_offset;
  int64_t bad = 0;
  for (int64_t i = 0; i < c.M; ++i) {
    bad += std::memcmp(sp + i * ldc, rp + i * ldc, size_t(c.N) * sizeof(T)) != 0;
    for (int64_t j = c.N; j < ldc && i + 1 < c.M; ++j) bad += !std::isnan(sp[i * ldc + j]);  // padding untouched
  }
  EXPECT_EQ(bad, 0) << "M=" << c.M << " N=" << c.N << " K=" << c.K << " ldc=" << ldc << " offset=" << c.c_offset
                    << " ta=" << ta << " tb=" << tb << " threads=" << t2m::get_num_threads();
  return streamed;
}

TEST(GemmStream, SameBitsAsGemmStreamedOrNot) {
  const int saved = t2m::get_num_threads();
  const int64_t big = t2m::gemm_l2_bytes();
  ASSERT_GE(big, 256 << 10);  // sysconf's L2 size, never below the floor
  const std::vector<Case> cases = {
      {rows_for(big, 512), 512, 32, 0, 0, true},          // the adaLN weight gradient's shape (K = the batch)
      {rows_for(big, 520) + 5, 520, 64, 8, 0, true},      // edge tiles (N % 32 = 8), short last row panel
      {rows_for(big, 1000), 1000, 512, 24, 0, true},      // K exactly one kernel block; ldc 1024
      {rows_for(big, 1000), 1000, 513, 24, 0, false},     // K over one block: C is read back
      {rows_for(big, 512), 512, 32, 1, 0, false},         // rows not 64-byte aligned
      {rows_for(big, 512), 512, 32, 0, 4, false},         // C itself not 64-byte aligned
      {rows_for(big / 4, 256), 256, 64, 0, 0, false},     // C smaller than the L2
      {40, 8, 3, 0, 0, false},                            // the small-shape path
  };
  for_each_kernel([&] {
    for (const Case& c : cases)
      for (int t = 0; t < 4; ++t)
        for (int threads : {1, 2}) {
          t2m::set_num_threads(threads);
          const bool ta = t & 1, tb = t & 2;
          EXPECT_EQ(check_case<float>(c, ta, tb), c.streams)
              << "M=" << c.M << " N=" << c.N << " K=" << c.K << " ldc pad " << c.ldc_pad << " offset " << c.c_offset;
        }
  });
  t2m::set_num_threads(2);
  EXPECT_FALSE(check_case<double>(cases[0], true, false));  // double: gemm's plain stores
  t2m::set_num_threads(saved);
}

TEST(GemmStream, BadArgumentsThrowLikeGemm) {
  std::vector<float> A(64, 1.0f), B(64, 1.0f), C(64, 0.0f);
  EXPECT_THROW(t2m::gemm_stream(false, false, -1, 4, 4, 1.0f, A.data(), 4, B.data(), 4, C.data(), 4), t2m::Error);
  EXPECT_THROW(t2m::gemm_stream(false, false, 4, 4, 4, 1.0f, A.data(), 4, B.data(), 4, C.data(), 3), t2m::Error);
  EXPECT_THROW(t2m::gemm_stream(false, false, 4, 4, 4, 1.0f, nullptr, 4, B.data(), 4, C.data(), 4), t2m::Error);
}

}  // namespace
