// test_gemm_segmented.cpp — t2m::gemm_segmented (columns stored in segments) against t2m::gemm on the same
// matrices gathered into plain storage: bit for bit, for both micro-kernels, all four transpose combinations,
// segment lengths shorter than, equal to, not dividing and longer than the register tile, 1 and 2 threads;
// the gaps between segments left untouched; bad segment arguments rejected.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "tensor/gemm.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"
#include "test_gemm_util.h"

namespace {

using t2m::GemmColumns;

// A rows x cols matrix whose columns lie in segments of `len` (0: plain): element (r, c) at
// r ld + (c / len) stride + c % len, with ld = len + 3 and stride past the segment's rows plus a gap, so that
// every segment sits in its own block like a sample of a (B, C, T) tensor. Everything else holds `pad`.
struct Segmented {
  int64_t rows, cols, ld;
  GemmColumns seg;
  std::vector<float> data;
  Segmented(int64_t r, int64_t c, int64_t len, float pad) : rows(r), cols(c) {
    if (len == 0) {
      ld = c + 2;
      data.assign(size_t(r * ld), pad);
    } else {
      ld = len + 3;
      seg = GemmColumns{len, r * ld + 5};
      data.assign(size_t((c + len - 1) / len * seg.stride), pad);
    }
  }
  size_t index(int64_t i, int64_t j) const {
    return size_t(i * ld + (seg.len ? j / seg.len * seg.stride + j % seg.len : j));
  }
  float& at(int64_t i, int64_t j) { return data[index(i, j)]; }
  std::vector<float> gathered() const {  // plain row-major, row stride cols
    std::vector<float> m(size_t(rows * cols));
    for (int64_t i = 0; i < rows; ++i)
      for (int64_t j = 0; j < cols; ++j) m[size_t(i * cols + j)] = data[index(i, j)];
    return m;
  }
};


bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

TEST(GemmSegmented, MatchesGemmOnGatheredMatricesBitForBit) {
  const int saved = t2m::get_num_threads();
  struct Shape3 { int64_t M, N, K; };
  // a panel-sized problem, one that splits by columns, K across two K blocks (512 and 256 deep), a tall one, one
  // that splits by columns with 512 rows or more (the threads pack A's K blocks together)
  const Shape3 shapes[] = {{40, 96, 70}, {25, 200, 600}, {256, 256, 300}, {300, 40, 1100}, {520, 300, 600}};
  const int64_t lens[] = {0, 1, 3, 8, 16, 32, 40, 100};
  std::mt19937 pick(5);
  for_each_kernel([&] {
    for (const Shape3 s : shapes)
      for (int t = 0; t < 4; ++t)
        for (int trial = 0; trial < 6; ++trial) {
          const bool ta = t & 1, tb = t & 2;
          const int64_t la = lens[pick() % 8], lb = lens[pick() % 8], lc = trial == 0 ? 0 : lens[pick() % 8];
          const float alpha = trial % 2 ? 0.75f : 1.0f, beta = trial % 3 == 1 ? 0.5f : 0.0f;
          std::mt19937 rng(uint32_t(17 + trial));
          std::uniform_real_distribution<float> u(-1.0f, 1.0f);
          const float nan = std::numeric_limits<float>::quiet_NaN(), mark = 12345.0f;
          Segmented A(ta ? s.K : s.M, ta ? s.M : s.K, la, nan), B(tb ? s.N : s.K, tb ? s.K : s.N, lb, nan);
          for (int64_t i = 0; i < A.rows; ++i)
            for (int64_t j = 0; j < A.cols; ++j) A.at(i, j) = u(rng);
          for (int64_t i = 0; i < B.rows; ++i)
            for (int64_t j = 0; j < B.cols; ++j) B.at(i, j) = u(rng);
          Segmented C0(s.M, s.N, lc, mark);
          for (int64_t i = 0; i < s.M; ++i)
            for (int64_t j = 0; j < s.N; ++j) C0.at(i, j) = u(rng);
          const std::vector<float> a = A.gathered(), b = B.gathered();
          for (int threads : {1, 2}) {
            t2m::set_num_threads(threads);
            std::vector<float> ref = C0.gathered();
            t2m::gemm(ta, tb, s.M, s.N, s.K, alpha, a.data(), A.cols, b.data(), B.cols, beta, ref.data(), s.N);
            Segmented C = C0;
            t2m::gemm_segmented(ta, tb, s.M, s.N, s.K, alpha, A.data.data(), A.ld, A.seg, B.data.data(), B.ld, B.seg,
                                beta, C.data.data(), C.ld, C.seg);
            const std::string where = "M=" + std::to_string(s.M) + " N=" + std::to_string(s.N) + " K=" +
                                      std::to_string(s.K) + " ta=" + std::to_string(ta) + " tb=" + std::to_string(tb) +
                                      " seg a/b/c=" + std::to_string(la) + "/" + std::to_string(lb) + "/" +
                                      std::to_string(lc) + " threads=" + std::to_string(threads);
            int64_t bad = 0, touched = 0;
            std::vector<bool> is_elem(C.data.size(), false);
            for (int64_t i = 0; i < s.M; ++i)
              for (int64_t j = 0; j < s.N; ++j) {
                is_elem[C.index(i, j)] = true;
                bad += !same_bits(C.at(i, j), ref[size_t(i * s.N + j)]);
              }
            for (size_t e = 0; e < C.data.size(); ++e) touched += !is_elem[e] && C.data[e] != mark;
            EXPECT_EQ(bad, 0) << "elements differing from gemm: " << where;
            EXPECT_EQ(touched, 0) << "gap elements written: " << where;
          }
        }
  });
  t2m::set_num_threads(saved);
}

// K == 0 only scales C (beta), run by run; double precision takes the same path as float.
TEST(GemmSegmented, EmptyProductScalesSegmentedCAndDoubleWorks) {
  std::vector<float> C = {1, 2, 9, 3, 4, 9};  // 1 x 4 in segments of 2 with a gap: columns at 0, 1, 3, 4
  t2m::gemm_segmented(false, false, 1, 4, 0, 1.0f, nullptr, 1, {}, nullptr, 4, {}, 2.0f, C.data(), 2, {2, 3});
  EXPECT_EQ(C, (std::vector<float>{2, 4, 9, 6, 8, 9}));
  // double: (2 x 3) @ (3 x 4, columns in segments of 2) = C (columns in segments of 2)
  const std::vector<double> A = {1, 2, 3, 4, 5, 6};
  const std::vector<double> B = {1, 0, 2, 1, 0, 1, 1, 2, 3, 1, 0, 1};  // segments [rows x 2] at 0 and 6, ld 2
  std::vector<double> Cd(12, -1.0);
  t2m::gemm_segmented(false, false, 2, 4, 3, 1.0, A.data(), 3, {}, B.data(), 2, {2, 6}, 0.0, Cd.data(), 2, {2, 4});
  // B logical: row0 = 1 0 | 1 2, row1 = 2 1 | 3 1, row2 = 0 1 | 0 1
  // segment 0 (columns 0, 1): rows at 0 and 2; segment 1 (columns 2, 3): rows at 4 and 6
  EXPECT_EQ(Cd[0], 1 * 1 + 2 * 2 + 3 * 0);
  EXPECT_EQ(Cd[1], 1 * 0 + 2 * 1 + 3 * 1);
  EXPECT_EQ(Cd[2], 4 * 1 + 5 * 2 + 6 * 0);
  EXPECT_EQ(Cd[3], 4 * 0 + 5 * 1 + 6 * 1);
  EXPECT_EQ(Cd[4], 1 * 1 + 2 * 3 + 3 * 0);
  EXPECT_EQ(Cd[5], 1 * 2 + 2 * 1 + 3 * 1);
  EXPECT_EQ(Cd[6], 4 * 1 + 5 * 3 + 6 * 0);
  EXPECT_EQ(Cd[7], 4 * 2 + 5 * 1 + 6 * 1);
}

TEST(GemmSegmented, BadSegmentsThrow) {
  std::vector<float> A(64, 1.0f), B(64, 1.0f), C(64, 0.0f);
  auto run = [&](GemmColumns a, GemmColumns b, GemmColumns c, int64_t ldc) {
    t2m::gemm_segmented(false, false, 4, 8, 4, 1.0f, A.data(), 4, a, B.data(), 8, b, 0.0f, C.data(), ldc, c);
  };
  EXPECT_THROW(run({-1, 4}, {}, {}, 8), t2m::Error);
  EXPECT_THROW(run({}, {4, 0}, {}, 8), t2m::Error);
  EXPECT_THROW(run({}, {}, {4, 16}, 3), t2m::Error);  // ldc must hold a segment's row of 4
  EXPECT_NO_THROW(run({}, {}, {4, 16}, 4));
  try {
    run({}, {2, -3}, {}, 8);
    FAIL() << "expected t2m::Error";
  } catch (const t2m::Error& e) {
    EXPECT_NE(std::string(e.what()).find("column segments of B"), std::string::npos) << e.what();
  }
}

}  // namespace
