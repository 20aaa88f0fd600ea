// test_promotion_viterbi.cpp — the Viterbi posture-planning decoder against brute-force enumeration of every path
// on small random lattices, exact ties, K = 1, and bad shapes.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "models/promotion/viterbi.h"
#include "tensor/rng.h"

namespace {

using namespace t2m;
using promotion::viterbi_decode;
using promotion::viterbi_path_score;

// Every path of the lattice; the best score, ties broken like the decoder (smallest last index, then the
// second-to-last, ...): compare candidate paths from the end.
promotion::ViterbiPath brute_force(const Tensor& e, const Tensor& a) {
  const int K = (int)e.size(0), N = (int)e.size(1);
  std::vector<int> p(K, 0);
  promotion::ViterbiPath best;
  best.score = -std::numeric_limits<double>::infinity();
  while (true) {
    const double s = viterbi_path_score(e, a, p);
    bool better = s > best.score;
    if (s == best.score) {
      for (int k = K - 1; k >= 0; --k) {
        if (p[k] != best.path[k]) {
          better = p[k] < best.path[k];
          break;
        }
      }
    }
    if (better) best.score = s, best.path = p;
    int k = 0;
    while (k < K && ++p[k] == N) p[k++] = 0;
    if (k == K) break;
  }
  return best;
}

TEST(Viterbi, MatchesBruteForceOnRandomLattices) {
  Generator g(7);
  for (int K = 1; K <= 5; ++K) {
    for (int N = 1; N <= 4; ++N) {
      for (int rep = 0; rep < 4; ++rep) {
        const Tensor e = rand_normal({K, N}, g, 0, 1, DType::f64);
        const Tensor a = rand_normal({K - 1, N, N}, g, 0, 1, DType::f64);
        const auto d = viterbi_decode(e, a);
        const auto b = brute_force(e, a);
        EXPECT_EQ(d.path, b.path) << "K=" << K << " N=" << N << " rep=" << rep;
        EXPECT_NEAR(d.score, b.score, 1e-12);
      }
    }
  }
}

TEST(Viterbi, TransitionsCanOverruleEmissions) {
  // Emissions prefer candidate 0 at every step, but 0 -> 0 transitions are heavily penalised.
  const Tensor e = Tensor::from_vector(std::vector<double>{1, 0, 1, 0, 1, 0}, {3, 2});
  std::vector<double> a = {-10, 0, 0, 0, -10, 0, 0, 0};
  const auto d = viterbi_decode(e, Tensor::from_vector(a, {2, 2, 2}));
  EXPECT_EQ(d.path, (std::vector<int>{0, 1, 0}));
  EXPECT_DOUBLE_EQ(d.score, 2.0);
}

TEST(Viterbi, TiesPickTheSmallestIndicesFromTheEnd) {
  Generator g(3);
  // Integer scores in a small range: many exact ties, all sums exact in double.
  for (int rep = 0; rep < 30; ++rep) {
    const int K = 4, N = 3;
    const Tensor e = randint({K, N}, g, -1, 2).to(DType::f64);
    const Tensor a = randint({K - 1, N, N}, g, -1, 2).to(DType::f64);
    const auto d = viterbi_decode(e, a);
    const auto b = brute_force(e, a);
    EXPECT_EQ(d.path, b.path) << "rep " << rep;
    EXPECT_EQ(d.score, b.score);
  }
  // All scores equal: the all-zero path.
  const auto z = viterbi_decode(Tensor::zeros({3, 4}), Tensor::zeros({2, 4, 4}));
  EXPECT_EQ(z.path, (std::vector<int>{0, 0, 0}));
}

TEST(Viterbi, SingleStepIsTheEmissionArgmax) {
  const Tensor e = Tensor::from_vector(std::vector<float>{0.1f, 2.5f, -1.f, 2.5f}, {1, 4});
  const auto d = viterbi_decode(e, Tensor());
  EXPECT_EQ(d.path, (std::vector<int>{1}));
  EXPECT_NEAR(d.score, 2.5, 1e-6);
  const auto d2 = viterbi_decode(e, Tensor::zeros({0, 4, 4}));
  EXPECT_EQ(d2.path, (std::vector<int>{1}));
}

TEST(Viterbi, AcceptsStridedFloat32) {
  Generator g(11);
  const Tensor e = rand_normal({4, 3}, g);
  const Tensor at = rand_normal({3, 3, 3}, g);
  const Tensor a_t = at.transpose(1, 2);  // a non-contiguous view
  const auto d = viterbi_decode(e, a_t);
  const auto b = brute_force(e.to(DType::f64), a_t.contiguous().to(DType::f64));
  EXPECT_EQ(d.path, b.path);
}

void expect_error(const Tensor& e, const Tensor& a, const std::string& what) {
  try {
    viterbi_decode(e, a);
    ADD_FAILURE() << "no error for " << what;
  } catch (const Error& err) {
    EXPECT_NE(std::string(err.what()).find("viterbi:"), std::string::npos) << err.what();
  }
}

TEST(Viterbi, RejectsBadShapes) {
  expect_error(Tensor::zeros({3}), Tensor::zeros({2, 3, 3}), "1-D emission");
  expect_error(Tensor::zeros({0, 3}), Tensor::zeros({0, 3, 3}), "K = 0");
  expect_error(Tensor::zeros({3, 0}), Tensor::zeros({2, 0, 0}), "N = 0");
  expect_error(Tensor::zeros({3, 2}), Tensor::zeros({3, 2, 2}), "K transitions instead of K-1");
  expect_error(Tensor::zeros({3, 2}), Tensor::zeros({2, 2, 3}), "non-square transition");
  expect_error(Tensor::zeros({3, 2}), Tensor(), "missing transition with K > 1");
  expect_error(Tensor::zeros({3, 2}, DType::i64), Tensor::zeros({2, 2, 2}), "integer emission");
  Tensor e = Tensor::zeros({2, 2});
  e.set({1, 1}, std::nan(""));
  expect_error(e, Tensor::zeros({1, 2, 2}), "NaN score");
  EXPECT_THROW(viterbi_path_score(Tensor::zeros({2, 2}), Tensor::zeros({1, 2, 2}), {0, 2}), Error);
  EXPECT_THROW(viterbi_path_score(Tensor::zeros({2, 2}), Tensor::zeros({1, 2, 2}), {0}), Error);
}

}  // namespace
