// test_gemm.cpp — t2m::gemm / gemm_batched against Eigen (computed in double), for both micro-kernels, all four
// transpose combinations, odd shapes, alpha/beta, sub-matrix strides, stride-0 batches, thread counts, bad input.
//
// Tolerance: the classic forward error bound |fl(C) - C| <= gamma_K (|alpha| |op(A)| |op(B)| + |beta| |C0|)
// with gamma_K ~ K * eps; we allow 2 (K + 2) eps per element, relative to that element's own magnitude sum.
#include <gtest/gtest.h>

#include <Eigen/Dense>
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

using t2m::gemm;
using t2m::gemm_batched;

template <typename T>
using RowMat = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using MatD = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// A row-major rows×cols matrix stored with row stride ld >= cols; the padding holds a sentinel (NaN for A/B,
// so reading it would poison the result; a fixed value for C, checked to be left untouched).
template <typename T>
struct Strided {
  int64_t rows, cols, ld;
  std::vector<T> data;
  Strided(int64_t r, int64_t c, int64_t ld_, T pad) : rows(r), cols(c), ld(ld_), data(size_t(std::max<int64_t>(r * ld_, 1)), pad) {}
  T& at(int64_t i, int64_t j) { return data[size_t(i * ld + j)]; }
  MatD to_eigen() const {
    MatD m(rows, cols);
    for (int64_t i = 0; i < rows; ++i)
      for (int64_t j = 0; j < cols; ++j) m(i, j) = double(data[size_t(i * ld + j)]);
    return m;
  }
};

template <typename T>
Strided<T> random_matrix(int64_t r, int64_t c, int64_t extra_ld, T pad, std::mt19937& rng) {
  Strided<T> s(r, c, std::max<int64_t>(c, 1) + extra_ld, pad);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int64_t i = 0; i < r; ++i)
    for (int64_t j = 0; j < c; ++j) s.at(i, j) = T(u(rng));
  return s;
}

template <typename T>
double eps() {
  return double(std::numeric_limits<T>::epsilon());
}

// Compares gemm(ta, tb, M, N, K, ...) with Eigen; returns the number of bad elements (0 expected).
template <typename T>
void check_gemm(bool ta, bool tb, int64_t M, int64_t N, int64_t K, T alpha, T beta, int64_t pad, uint32_t seed) {
  SCOPED_TRACE("ta=" + std::to_string(ta) + " tb=" + std::to_string(tb) + " M=" + std::to_string(M) + " N=" +
               std::to_string(N) + " K=" + std::to_string(K) + " alpha=" + std::to_string(alpha) +
               " beta=" + std::to_string(beta) + " pad=" + std::to_string(pad) + " kernel=" + t2m::gemm_kernel_name());
  std::mt19937 rng(seed);
  const T nan = std::numeric_limits<T>::quiet_NaN();
  auto A = ta ? random_matrix<T>(K, M, pad, nan, rng) : random_matrix<T>(M, K, pad, nan, rng);
  auto B = tb ? random_matrix<T>(N, K, pad, nan, rng) : random_matrix<T>(K, N, pad, nan, rng);
  const T sentinel = T(12345);
  auto C = random_matrix<T>(M, N, pad, sentinel, rng);
  if (beta == T(0))  // beta == 0 must never read C: fill it with NaN
    for (int64_t i = 0; i < M; ++i)
      for (int64_t j = 0; j < N; ++j) C.at(i, j) = nan;
  const MatD a = ta ? MatD(A.to_eigen().transpose()) : A.to_eigen();
  const MatD b = tb ? MatD(B.to_eigen().transpose()) : B.to_eigen();
  const MatD c0 = beta == T(0) ? MatD(MatD::Zero(M, N)) : C.to_eigen();
  const MatD ref = double(alpha) * (a * b) + double(beta) * c0;
  const MatD bound = std::abs(double(alpha)) * (a.cwiseAbs() * b.cwiseAbs()) + std::abs(double(beta)) * c0.cwiseAbs();

  gemm(ta, tb, M, N, K, alpha, A.data.data(), A.ld, B.data.data(), B.ld, beta, C.data.data(), C.ld);

  const double tol = 2.0 * double(K + 2) * eps<T>();
  int bad = 0;
  for (int64_t i = 0; i < M; ++i) {
    for (int64_t j = 0; j < N; ++j) {
      const double got = double(C.at(i, j));
      const double err = std::abs(got - ref(i, j));
      if (!(err <= tol * bound(i, j) + 1e-30) && bad++ < 5)
        ADD_FAILURE() << "C[" << i << "," << j << "] = " << got << ", expected " << ref(i, j) << " (err " << err
                      << ", allowed " << tol * bound(i, j) << ")";
    }
    for (int64_t j = N; j < C.ld; ++j)
      if (C.at(i, j) != sentinel && bad++ < 5) ADD_FAILURE() << "padding of C row " << i << " col " << j << " written";
  }
  EXPECT_EQ(bad, 0);
}


const std::vector<int64_t> kOddSizes = {1, 2, 7, 15, 16, 17, 33, 64};

template <typename T>
void odd_shapes_all_transposes() {
  for_each_kernel([] {
    uint32_t seed = 1;
    for (int t = 0; t < 4; ++t)
      for (int64_t M : kOddSizes)
        for (int64_t N : kOddSizes)
          for (int64_t K : {int64_t(1), int64_t(7), int64_t(17), int64_t(64)})
            check_gemm<T>(t & 1, t & 2, M, N, K, T(1), T(0), 0, seed++);
  });
}
TEST(Gemm, FloatOddShapesAllTransposes) { odd_shapes_all_transposes<float>(); }
TEST(Gemm, DoubleOddShapesAllTransposes) { odd_shapes_all_transposes<double>(); }

// Larger shapes that cross the register tile, the cache blocks (avx512: mc 192, kc 512, nc 4096) and mixed
// tiny/large dims.
template <typename T>
void larger_shapes() {
  struct Shape3 { int64_t M, N, K; };
  const std::vector<Shape3> shapes = {{127, 257, 33}, {257, 127, 64}, {1, 257, 33}, {257, 1, 33}, {33, 257, 1},
                                      {127, 127, 127}, {257, 257, 257}, {400, 70, 600}, {13, 4100, 5}, {3, 45, 300},
                                      {300, 1, 700}, {1, 300, 700}};
  for_each_kernel([&] {
    uint32_t seed = 100;
    for (int t = 0; t < 4; ++t)
      for (const auto& s : shapes) check_gemm<T>(t & 1, t & 2, s.M, s.N, s.K, T(1), T(0), 0, seed++);
  });
}
TEST(Gemm, FloatLargerShapes) { larger_shapes<float>(); }

// Row counts that leave a short last row panel with a kernel of its own (MicroKernel::short_m: avx512 mr 12 ->
// 4 and 8 rows, avx2 mr 6 -> 2 and 4) with full column panels, across K blocks (kc 512) and with beta != 0.
TEST(Gemm, FloatShortRowPanels) {
  for_each_kernel([] {
    uint32_t seed = 500;
    for (int t = 0; t < 4; ++t)
      for (const int64_t M : {4, 8, 14, 16, 20, 44, 256})
        for (const int64_t K : {33, 600}) {
          check_gemm<float>(t & 1, t & 2, M, 64, K, 1.0f, 0.0f, 0, seed++);
          check_gemm<float>(t & 1, t & 2, M, 96, K, -0.5f, 1.5f, 3, seed++);
        }
  });
}
TEST(Gemm, DoubleLargerShapes) { larger_shapes<double>(); }

template <typename T>
void alpha_beta_and_strides() {
  const std::vector<std::pair<T, T>> ab = {{T(1), T(0)}, {T(0.5), T(2)}, {T(-1.5), T(1)}, {T(2), T(-0.25)},
                                           {T(0), T(0.5)}, {T(0), T(0)}};
  for_each_kernel([&] {
    uint32_t seed = 1000;
    for (int t = 0; t < 4; ++t)
      for (const auto& [alpha, beta] : ab)
        for (int64_t pad : {0, 3}) {
          check_gemm<T>(t & 1, t & 2, 37, 45, 29, alpha, beta, pad, seed++);   // packed path
          check_gemm<T>(t & 1, t & 2, 2, 45, 29, alpha, beta, pad, seed++);    // small path (M tiny)
          check_gemm<T>(t & 1, t & 2, 45, 37, 0, alpha, beta, pad, seed++);    // K == 0: C = beta C
          check_gemm<T>(t & 1, t & 2, 200, 40, 530, alpha, beta, pad, seed++); // two mc and kc blocks, edges
        }
  });
}
TEST(Gemm, FloatAlphaBetaAndSubmatrixStrides) { alpha_beta_and_strides<float>(); }
TEST(Gemm, DoubleAlphaBetaAndSubmatrixStrides) { alpha_beta_and_strides<double>(); }

// Batched: every product checked against its own Eigen reference; stride 0 broadcasts A or B.
template <typename T>
void batched(int64_t batch, int64_t M, int64_t N, int64_t K, bool ta, bool tb, bool bcast_a, bool bcast_b) {
  SCOPED_TRACE("batched batch=" + std::to_string(batch) + " M=" + std::to_string(M) + " N=" + std::to_string(N) +
               " K=" + std::to_string(K) + " ta=" + std::to_string(ta) + " tb=" + std::to_string(tb) +
               " bcast_a=" + std::to_string(bcast_a) + " bcast_b=" + std::to_string(bcast_b));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int64_t sa = bcast_a ? 0 : M * K, sb = bcast_b ? 0 : K * N, sc = M * N;
  std::vector<T> A(size_t(bcast_a ? M * K : batch * M * K)), B(size_t(bcast_b ? K * N : batch * K * N));
  std::vector<T> C(size_t(batch * M * N));
  for (auto& v : A) v = T(u(rng));
  for (auto& v : B) v = T(u(rng));
  for (auto& v : C) v = T(u(rng));
  const std::vector<T> C0 = C;
  const T alpha = T(0.75), beta = T(-0.5);
  gemm_batched(ta, tb, batch, M, N, K, alpha, A.data(), ta ? M : K, sa, B.data(), tb ? K : N, sb, beta, C.data(), N, sc);
  const double tol = 2.0 * double(K + 2) * eps<T>();
  int bad = 0;
  for (int64_t b = 0; b < batch; ++b) {
    Eigen::Map<const RowMat<T>> a(A.data() + b * sa, ta ? K : M, ta ? M : K);
    Eigen::Map<const RowMat<T>> bm(B.data() + b * sb, tb ? N : K, tb ? K : N);
    Eigen::Map<const RowMat<T>> c0(C0.data() + b * sc, M, N);
    const MatD ad = ta ? MatD(a.template cast<double>().transpose()) : MatD(a.template cast<double>());
    const MatD bd = tb ? MatD(bm.template cast<double>().transpose()) : MatD(bm.template cast<double>());
    const MatD ref = double(alpha) * (ad * bd) + double(beta) * c0.template cast<double>();
    const MatD bound = std::abs(double(alpha)) * (ad.cwiseAbs() * bd.cwiseAbs()) +
                       std::abs(double(beta)) * c0.template cast<double>().cwiseAbs();
    for (int64_t i = 0; i < M; ++i)
      for (int64_t j = 0; j < N; ++j) {
        const double err = std::abs(double(C[size_t(b * sc + i * N + j)]) - ref(i, j));
        if (!(err <= tol * bound(i, j) + 1e-30) && bad++ < 5)
          ADD_FAILURE() << "batch " << b << " C[" << i << "," << j << "] err " << err;
      }
  }
  EXPECT_EQ(bad, 0);
}

TEST(Gemm, BatchedWithBroadcastStrides) {
  const int saved = t2m::get_num_threads();
  for (int threads : {1, 2}) {
    t2m::set_num_threads(threads);
    for (int t = 0; t < 4; ++t) {
      batched<float>(9, 17, 33, 15, t & 1, t & 2, false, false);  // small: threads across the batch
      batched<float>(9, 17, 33, 15, t & 1, t & 2, true, false);
      batched<float>(9, 17, 33, 15, t & 1, t & 2, false, true);
      batched<float>(3, 130, 140, 150, t & 1, t & 2, false, true);  // threads within each product
      batched<double>(5, 20, 30, 40, t & 1, t & 2, true, false);
    }
  }
  t2m::set_num_threads(saved);
}

// Random operands of an M x N x K product (entries in [-1, 1), A before B before the bias, from one seed) and the
// row strides of op(A) = A^T when ta, op(B) = B^T when tb.
template <typename T>
struct Operands {
  std::vector<T> A, B, bias;
  int64_t lda, ldb;
  Operands(int64_t M, int64_t N, int64_t K, bool ta, bool tb, uint32_t seed)
      : A(size_t(std::max<int64_t>(1, M * K))), B(size_t(std::max<int64_t>(1, K * N))), bias(size_t(N)),
        lda(ta ? M : std::max<int64_t>(1, K)), ldb(tb ? std::max<int64_t>(1, K) : N) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (auto* v : {&A, &B, &bias})
      for (auto& x : *v) x = T(u(rng));
  }
};

// gemm_bias (the bias joins in the final store) gives the bits of the two-pass form it replaces: C filled with the
// bias rows, then gemm with beta = 1; across the small-shape path, edge tiles, short row panels, two K blocks
// (kc 512), alpha != 1, both kernels and 1 and 2 threads.
template <typename T>
void bias_matches_two_pass() {
  const int saved = t2m::get_num_threads();
  struct Shape3 { int64_t M, N, K; };
  for_each_kernel([] {
    for (const Shape3 s : {Shape3{2, 7, 5}, Shape3{20, 64, 33}, Shape3{44, 100, 600}, Shape3{256, 96, 70},
                           Shape3{5, 300, 1}, Shape3{13, 40, 0}})
      for (int t = 0; t < 4; ++t)
        for (const T alpha : {T(1), T(-0.75)})
          for (int threads : {1, 2}) {
            t2m::set_num_threads(threads);
            const bool ta = t & 1, tb = t & 2;
            const Operands<T> o(s.M, s.N, s.K, ta, tb, uint32_t(s.M * 7 + s.N + t));
            const auto& [A, B, bias, lda, ldb] = o;
            std::vector<T> fused(size_t(s.M * s.N), std::numeric_limits<T>::quiet_NaN()), two(size_t(s.M * s.N));
            for (int64_t i = 0; i < s.M; ++i) std::copy(bias.begin(), bias.end(), two.begin() + i * s.N);
            t2m::gemm_bias(ta, tb, s.M, s.N, s.K, alpha, A.data(), lda, B.data(), ldb, bias.data(), fused.data(),
                           s.N);
            if (alpha == T(1)) {
              t2m::gemm(ta, tb, s.M, s.N, s.K, alpha, A.data(), lda, B.data(), ldb, T(1), two.data(), s.N);
              EXPECT_EQ(fused, two) << "M=" << s.M << " N=" << s.N << " K=" << s.K << " t=" << t;
            } else {  // alpha scales the product only: compare with the reference within rounding
              t2m::gemm(ta, tb, s.M, s.N, s.K, alpha, A.data(), lda, B.data(), ldb, T(0), two.data(), s.N);
              for (int64_t i = 0; i < s.M; ++i)
                for (int64_t j = 0; j < s.N; ++j)
                  EXPECT_NEAR(double(fused[size_t(i * s.N + j)]), double(two[size_t(i * s.N + j)] + bias[size_t(j)]),
                              1e-5)
                      << "M=" << s.M << " N=" << s.N << " K=" << s.K << " t=" << t << " (" << i << "," << j << ")";
            }
          }
  });
  t2m::set_num_threads(saved);
}
TEST(Gemm, FloatBiasMatchesTwoPass) { bias_matches_two_pass<float>(); }
TEST(Gemm, DoubleBiasMatchesTwoPass) { bias_matches_two_pass<double>(); }

// gemm_bias_relu gives the bits of gemm_bias followed by relu (x < 0 ? 0 : x, NaN kept) on the small-shape path,
// full and edge tiles, short row panels, two and three K blocks (the ReLU after the last one only), K == 0, both
// kernels, 1 and 2 threads. A NaN in A shows the NaN passes the ReLU.
template <typename T>
void bias_relu_matches_two_pass() {
  const int saved = t2m::get_num_threads();
  struct Shape3 { int64_t M, N, K; };
  for_each_kernel([] {
    for (const Shape3 s : {Shape3{2, 7, 5}, Shape3{20, 64, 33}, Shape3{44, 100, 600}, Shape3{256, 96, 70},
                           Shape3{100, 300, 1100}, Shape3{13, 40, 0}}) {
      for (int t = 0; t < 4; ++t) {
        for (int threads : {1, 2}) {
          t2m::set_num_threads(threads);
          const bool ta = t & 1, tb = t & 2;
          Operands<T> o(s.M, s.N, s.K, ta, tb, uint32_t(s.M * 5 + s.N + t));
          if (s.K > 0) o.A[0] = std::numeric_limits<T>::quiet_NaN();
          const auto& [A, B, bias, lda, ldb] = o;
          std::vector<T> fused(size_t(s.M * s.N), T(7)), two(size_t(s.M * s.N), T(7));
          t2m::gemm_bias_relu(ta, tb, s.M, s.N, s.K, T(1), A.data(), lda, B.data(), ldb, bias.data(), fused.data(),
                              s.N);
          t2m::gemm_bias(ta, tb, s.M, s.N, s.K, T(1), A.data(), lda, B.data(), ldb, bias.data(), two.data(), s.N);
          size_t zeros = 0;
          for (auto& v : two) {
            zeros += v < T(0);
            v = v < T(0) ? T(0) : v;
          }
          EXPECT_GT(zeros, 0u) << "M=" << s.M << " N=" << s.N << " K=" << s.K;
          ASSERT_EQ(fused.size(), two.size());
          for (size_t i = 0; i < two.size(); ++i) {
            ASSERT_TRUE(std::memcmp(&fused[i], &two[i], sizeof(T)) == 0)
                << "M=" << s.M << " N=" << s.N << " K=" << s.K << " t=" << t << " threads=" << threads << " at "
                << i << ": " << fused[i] << " vs " << two[i];
          }
          if (s.K > 0) {
            EXPECT_TRUE(std::isnan(fused[0]));
          }
        }
      }
    }
  });
  t2m::set_num_threads(saved);
}
TEST(Gemm, FloatBiasReluMatchesTwoPass) { bias_relu_matches_two_pass<float>(); }
TEST(Gemm, DoubleBiasReluMatchesTwoPass) { bias_relu_matches_two_pass<double>(); }

// stride_c == 0: every product accumulates into the same C (beta = 1 sums over the batch).
TEST(Gemm, BatchedStrideZeroOutputAccumulates) {
  const int64_t batch = 6, M = 19, N = 23, K = 11;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<float> A(size_t(batch * M * K)), B(size_t(batch * K * N)), C(size_t(M * N), 0.0f);
  for (auto& v : A) v = float(u(rng));
  for (auto& v : B) v = float(u(rng));
  gemm_batched(false, false, batch, M, N, K, 1.0f, A.data(), K, M * K, B.data(), N, K * N, 1.0f, C.data(), N, 0);
  MatD ref = MatD::Zero(M, N);
  for (int64_t b = 0; b < batch; ++b)
    ref += Eigen::Map<const RowMat<float>>(A.data() + b * M * K, M, K).cast<double>() *
           Eigen::Map<const RowMat<float>>(B.data() + b * K * N, K, N).cast<double>();
  for (int64_t i = 0; i < M; ++i)
    for (int64_t j = 0; j < N; ++j) EXPECT_NEAR(C[size_t(i * N + j)], ref(i, j), 1e-4) << i << "," << j;
}

// For a fixed thread count results are reproducible, and the split never changes an element's arithmetic,
// so 1 and 2 threads agree bit for bit. With 2 threads the packed path hands out (row block, B panel) items by
// work stealing, whose order varies from run to run: repeated runs must still agree bit for bit.
TEST(Gemm, ThreadCountsGiveIdenticalResults) {
  const int saved = t2m::get_num_threads();
  struct Shape3 { int64_t M, N, K; };
  for_each_kernel([] {
    // split by rows (300x200; 600x256, which has B panels enough for a column split but N <= M/2), by columns
    // with one K block (40x900, 256x1024) and three (200x700x1300: the stealing threads meet after each block; 530x800:
    // 512 rows or more, so the threads pack A's K blocks together, a short last row panel included; 40x900x1100:
    // one row block, so with op(B) = B^T each B panel is packed just before its use), one thread's share (513x33)
    for (const Shape3 s : {Shape3{300, 200, 600}, Shape3{600, 256, 700}, Shape3{40, 900, 70}, Shape3{513, 33, 64},
                           Shape3{256, 1024, 256}, Shape3{200, 700, 1300}, Shape3{530, 800, 1100},
                           Shape3{40, 900, 1100}}) {
      for (int t = 0; t < 4; ++t) {
        const bool ta = t & 1, tb = t & 2;
        std::mt19937 rng(11);
        std::uniform_real_distribution<float> u(-1.0f, 1.0f);
        std::vector<float> A(size_t(s.M * s.K)), B(size_t(s.K * s.N));
        for (auto& v : A) v = u(rng);
        for (auto& v : B) v = u(rng);
        std::vector<float> bias(size_t(s.N));
        for (auto& v : bias) v = u(rng);
        std::vector<std::vector<float>> out;
        for (int threads : {1, 2, 2, 2, 2}) {
          t2m::set_num_threads(threads);
          std::vector<float> C(size_t(s.M * s.N), std::numeric_limits<float>::quiet_NaN());
          if (t == 3)  // with a bias (it joins in the first K block)
            t2m::gemm_bias(ta, tb, s.M, s.N, s.K, 1.0f, A.data(), ta ? s.M : s.K, B.data(), tb ? s.K : s.N, bias.data(),
                      C.data(), s.N);
          else
            gemm(ta, tb, s.M, s.N, s.K, 1.0f, A.data(), ta ? s.M : s.K, B.data(), tb ? s.K : s.N, 0.0f, C.data(),
                 s.N);
          out.push_back(std::move(C));
        }
        for (size_t r = 2; r < out.size(); ++r)
          EXPECT_EQ(out[1], out[r]) << "2 threads not reproducible, M=" << s.M << " N=" << s.N << " K=" << s.K;
        EXPECT_EQ(out[0], out[1]) << "1 vs 2 threads differ, M=" << s.M << " N=" << s.N << " K=" << s.K;
      }
    }
  });
  t2m::set_num_threads(saved);
}

// The matrix-vector path (one row of A against B^T) sums four output columns at a time; each column must get
// exactly the bits it gets when computed alone (N = 1), so a policy's actions do not depend on the layer width.
TEST(Gemm, SmallRowPathColumnsMatchSingleColumnBits) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (const int64_t K : {5, 8, 37, 614}) {
    const int64_t N = 11;  // two blocks of four and a tail of three
    std::vector<float> a(static_cast<size_t>(K)), B(static_cast<size_t>(N * K));
    for (auto& v : a) v = u(rng);
    for (auto& v : B) v = u(rng);
    std::vector<float> c(size_t(N), std::numeric_limits<float>::quiet_NaN());
    gemm(false, true, 1, N, K, 1.0f, a.data(), K, B.data(), K, 0.0f, c.data(), N);
    double ref_err = 0;
    for (int64_t j = 0; j < N; ++j) {
      float one = std::numeric_limits<float>::quiet_NaN();
      gemm(false, true, 1, 1, K, 1.0f, a.data(), K, B.data() + j * K, K, 0.0f, &one, 1);
      EXPECT_EQ(c[size_t(j)], one) << "column " << j << ", K=" << K;
      double ref = 0;
      for (int64_t k = 0; k < K; ++k) ref += double(a[size_t(k)]) * double(B[size_t(j * K + k)]);
      ref_err = std::max(ref_err, std::abs(ref - double(c[size_t(j)])));
    }
    EXPECT_LT(ref_err, 1e-4) << "K=" << K;
  }
}

TEST(Gemm, KernelChoice) {
  t2m::gemm_force_kernel("auto");
  const bool avx512 = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                      __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl");
  EXPECT_STREQ(t2m::gemm_kernel_name(), avx512 ? "avx512" : "avx2");
  if (!avx512) {
    EXPECT_THROW(t2m::gemm_force_kernel("avx512"), t2m::Error);
  }
  EXPECT_THROW(t2m::gemm_force_kernel("sse9"), t2m::Error);
  EXPECT_THROW(t2m::gemm_force_kernel(nullptr), t2m::Error);
  EXPECT_STREQ(t2m::gemm_kernel_name(), avx512 ? "avx512" : "avx2");  // a failed force changes nothing
}

TEST(Gemm, BadArgumentsThrow) {
  std::vector<float> A(64, 1.0f), B(64, 1.0f), C(64, 0.0f);
  EXPECT_THROW(gemm(false, false, -1, 4, 4, 1.0f, A.data(), 4, B.data(), 4, 0.0f, C.data(), 4), t2m::Error);
  EXPECT_THROW(gemm(false, false, 4, 4, 4, 1.0f, A.data(), 3, B.data(), 4, 0.0f, C.data(), 4), t2m::Error);  // lda < K
  EXPECT_THROW(gemm(true, false, 5, 4, 4, 1.0f, A.data(), 4, B.data(), 4, 0.0f, C.data(), 4), t2m::Error);   // lda < M
  EXPECT_THROW(gemm(false, true, 4, 4, 5, 1.0f, A.data(), 5, B.data(), 4, 0.0f, C.data(), 4), t2m::Error);   // ldb < K
  EXPECT_THROW(gemm(false, false, 4, 5, 4, 1.0f, A.data(), 4, B.data(), 5, 0.0f, C.data(), 4), t2m::Error);  // ldc < N
  EXPECT_THROW(gemm(false, false, 4, 4, 4, 1.0f, nullptr, 4, B.data(), 4, 0.0f, C.data(), 4), t2m::Error);
  EXPECT_THROW(gemm_batched(false, false, -2, 4, 4, 4, 1.0f, A.data(), 4, 16, B.data(), 4, 16, 0.0f, C.data(), 4, 16),
               t2m::Error);
  EXPECT_THROW(gemm_batched(false, false, 2, 4, 4, 4, 1.0f, A.data(), 4, -16, B.data(), 4, 16, 0.0f, C.data(), 4, 16),
               t2m::Error);
  try {
    gemm(false, false, 4, 4, 4, 1.0f, A.data(), 3, B.data(), 4, 0.0f, C.data(), 4);
  } catch (const t2m::Error& e) {
    EXPECT_NE(std::string(e.what()).find("lda"), std::string::npos) << e.what();
  }
  // Empty problems are fine and touch nothing.
  EXPECT_NO_THROW(gemm(false, false, 0, 4, 4, 1.0f, A.data(), 4, B.data(), 4, 0.0f, C.data(), 4));
}

}  // namespace
