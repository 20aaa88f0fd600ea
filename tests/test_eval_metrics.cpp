// test_eval_metrics.cpp — the evaluation metrics on synthetic embeddings with known answers: distance matrix,
// R-precision (perfect = 1, ties, naive reference, chance level k/32 for unrelated and caption-shuffled
// embeddings), FID (identical sets = 0, closed forms, sampled Gaussians), MM-Dist, Diversity, MultiModality,
// mean +- 95% CI, determinism and bad shapes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <vector>

#include "models/eval/metrics.h"
#include "tensor/ops.h"
#include "tensor/rng.h"
#include "test_tensor_util.h"

using namespace t2m;
using t2m::testing::randn;
using namespace t2m::eval;
using t2m::testing::expect_error;

namespace {

double naive_dist(const Tensor& a, int64_t i, const Tensor& b, int64_t j) {
  double s = 0;
  for (int64_t k = 0; k < a.size(1); ++k) {
    double d = a.at({i, k}) - b.at({j, k});
    s += d * d;
  }
  return std::sqrt(s);
}

// Guo et al.'s R-precision written out independently: the same batch permutation, a full sort per text, and the
// true motion placed after every motion at equal distance.
std::vector<double> naive_r_precision(const Tensor& text, const Tensor& motion, uint64_t seed, int top_k, int bs) {
  Generator g(seed);
  auto perm = randperm(text.size(0), g);
  const int64_t batches = text.size(0) / bs;
  std::vector<double> hits(top_k, 0.0);
  for (int64_t b = 0; b < batches; ++b) {
    for (int i = 0; i < bs; ++i) {
      std::vector<std::pair<double, int>> order;  // (distance, 1 for the true motion so it sorts after ties)
      for (int j = 0; j < bs; ++j)
        order.push_back({naive_dist(text, perm[b * bs + i], motion, perm[b * bs + j]), j == i ? 1 : 0});
      std::sort(order.begin(), order.end());
      for (int r = 0; r < bs; ++r)
        if (order[r].second == 1)
          for (int k = r; k < top_k; ++k) hits[k] += 1.0;
    }
  }
  for (auto& h : hits) h /= (double)(batches * bs);
  return hits;
}

}  // namespace

TEST(EvalMetrics, DistanceMatrixMatchesNaive) {
  Tensor a = Tensor::from_vector(std::vector<double>{0, 0, 3, 4, 1, 1}, {3, 2});
  Tensor b = Tensor::from_vector(std::vector<double>{0, 0, 6, 8}, {2, 2});
  Tensor d = euclidean_distance_matrix(a, b);
  ASSERT_EQ(d.shape(), (Shape{3, 2}));
  ASSERT_EQ(d.dtype(), DType::f64);
  EXPECT_DOUBLE_EQ(d.at({0, 0}), 0.0);
  EXPECT_DOUBLE_EQ(d.at({0, 1}), 10.0);
  EXPECT_DOUBLE_EQ(d.at({1, 0}), 5.0);
  EXPECT_DOUBLE_EQ(d.at({1, 1}), 5.0);
  EXPECT_DOUBLE_EQ(d.at({2, 1}), std::sqrt(25.0 + 49.0));
  // float32 input, non-contiguous (transposed) view, a size that takes the parallel path.
  Tensor x = randn({40, 70}, 1, DType::f32).transpose(0, 1);  // (70, 40)
  Tensor y = randn({90, 40}, 2, DType::f32);
  Tensor dm = euclidean_distance_matrix(x, y);
  ASSERT_EQ(dm.shape(), (Shape{70, 90}));
  for (int64_t i = 0; i < 70; i += 7)
    for (int64_t j = 0; j < 90; j += 11) EXPECT_NEAR(dm.at({i, j}), naive_dist(x, i, y, j), 1e-12);
}

TEST(EvalMetrics, RPrecisionOfPerfectMatchesIsOne) {
  Tensor t = randn({330, 16}, 3);
  Generator g(7);
  RPrecision r = r_precision(t, t.clone(), g);
  EXPECT_EQ(r.batches, 10);
  EXPECT_EQ(r.samples, 320);
  EXPECT_EQ(r.top, (std::vector<double>{1.0, 1.0, 1.0}));
  Generator g2(7);
  EXPECT_EQ(r_precision(t.to(DType::f32), t.to(DType::f32), g2, 5).top, std::vector<double>(5, 1.0));
}

TEST(EvalMetrics, RPrecisionTiesCountAgainstTheTrueMotion) {
  // 1-D embeddings: text i = i, motion i = i except motion 1 = 0.
  // text 0: d00 = d01 = 0 -> rank 1; text 1: d11 = d10 = d12 = 1 -> rank 2; others rank 0.
  std::vector<double> tv(32), mv(32);
  for (int i = 0; i < 32; ++i) tv[i] = mv[i] = i;
  mv[1] = 0;
  Tensor text = Tensor::from_vector(tv, {32, 1}), motion = Tensor::from_vector(mv, {32, 1});
  Generator g(1);
  RPrecision r = r_precision(text, motion, g, 3);
  EXPECT_DOUBLE_EQ(r.top[0], 30.0 / 32.0);
  EXPECT_DOUBLE_EQ(r.top[1], 31.0 / 32.0);
  EXPECT_DOUBLE_EQ(r.top[2], 1.0);
  // All motions equal: every text sees 31 ties, so no hit even at top-31; top-32 always hits.
  Tensor same = Tensor::zeros({64, 4});
  Generator g2(2);
  RPrecision r2 = r_precision(randn({64, 4}, 4), same, g2, 32);
  EXPECT_EQ(r2.top[0], 0.0);
  EXPECT_EQ(r2.top[30], 0.0);
  EXPECT_EQ(r2.top[31], 1.0);
}

TEST(EvalMetrics, RPrecisionMatchesNaiveReference) {
  Tensor text = randn({200, 6}, 11);
  Tensor motion = add(text, mul(randn({200, 6}, 12), 1.3));  // noisy: hits in between 0 and 1
  Generator g(99);
  RPrecision r = r_precision(text, motion, g, 4, 16);
  auto want = naive_r_precision(text, motion, 99, 4, 16);
  EXPECT_EQ(r.batches, 12);
  ASSERT_EQ(r.top.size(), 4u);
  for (int k = 0; k < 4; ++k) EXPECT_DOUBLE_EQ(r.top[k], want[k]) << "top-" << k + 1;
  EXPECT_GT(r.top[0], 0.2);
  EXPECT_LT(r.top[0], 0.95);
  // Same seed, same result; another seed, other batches.
  Generator g2(99), g3(100);
  EXPECT_EQ(r_precision(text, motion, g2, 4, 16).top, r.top);
  EXPECT_NE(r_precision(text, motion, g3, 4, 16).top, r.top);
}

TEST(EvalMetrics, RPrecisionOfUnrelatedEmbeddingsIsChance) {
  const int64_t N = 32 * 300;
  Tensor text = randn({N, 8}, 21), motion = randn({N, 8}, 22);
  Generator g(5);
  RPrecision r = r_precision(text, motion, g);
  for (int k = 1; k <= 3; ++k) {
    const double p = k / 32.0, tol = 4.5 * std::sqrt(p * (1 - p) / (double)N);
    EXPECT_NEAR(r.top[k - 1], p, tol) << "top-" << k;
  }
}

TEST(EvalMetrics, CaptionShuffledControlFallsToChance) {
  const int64_t N = 32 * 300;
  Tensor motion = randn({N, 8}, 31);
  Tensor text = add(motion, mul(randn({N, 8}, 32), 0.05));  // well aligned encoders
  Generator g(6);
  RPrecision real = r_precision(text, motion, g);
  EXPECT_GT(real.top[0], 0.99);
  Generator g2(6);
  RPrecision ctl = shuffled_r_precision(text, motion, g2);
  std::printf("aligned R-precision top-1/2/3 %.4f %.4f %.4f; caption-shuffled control %.4f %.4f %.4f (chance %.4f "
              "%.4f %.4f)\n", real.top[0], real.top[1], real.top[2], ctl.top[0], ctl.top[1], ctl.top[2], 1 / 32.0,
              2 / 32.0, 3 / 32.0);
  for (int k = 1; k <= 3; ++k) {
    const double p = k / 32.0, tol = 4.5 * std::sqrt(p * (1 - p) / (double)N);
    EXPECT_NEAR(ctl.top[k - 1], p, tol) << "top-" << k;
  }
  // Mean +- CI over 20 seeded runs of the control: the mean is at chance.
  auto ci = repeat_runs(20, 1234, [&](Generator& gen, int) { return shuffled_r_precision(text, motion, gen).top; });
  ASSERT_EQ(ci.size(), 3u);
  for (int k = 1; k <= 3; ++k) {
    EXPECT_NEAR(ci[k - 1].mean, k / 32.0, 0.005) << "top-" << k;
    EXPECT_GT(ci[k - 1].ci95, 0.0);
    EXPECT_LT(ci[k - 1].ci95, 0.005);
  }
}

TEST(EvalMetrics, FeatureStatisticsMatchNaive) {
  Tensor x = randn({50, 3}, 41);
  FeatureStatistics s = feature_statistics(x.to(DType::f32));
  ASSERT_EQ(s.mean.shape(), (Shape{3}));
  ASSERT_EQ(s.cov.shape(), (Shape{3, 3}));
  EXPECT_EQ(s.n, 50);
  Tensor xf = x.to(DType::f32).to(DType::f64);
  for (int64_t a = 0; a < 3; ++a) {
    double ma = 0;
    for (int64_t i = 0; i < 50; ++i) ma += xf.at({i, a}) / 50.0;
    EXPECT_NEAR(s.mean.at({a}), ma, 1e-12);
    for (int64_t b = 0; b < 3; ++b) {
      double mb = 0, c = 0;
      for (int64_t i = 0; i < 50; ++i) mb += xf.at({i, b}) / 50.0;
      for (int64_t i = 0; i < 50; ++i) c += (xf.at({i, a}) - ma) * (xf.at({i, b}) - mb) / 49.0;
      EXPECT_NEAR(s.cov.at({a, b}), c, 1e-12);
    }
  }
}

TEST(EvalMetrics, FidOfIdenticalSetsIsZero) {
  Tensor x = randn({500, 12}, 51);
  EXPECT_NEAR(fid(x, x), 0.0, 1e-9);
  // Row order does not matter.
  Generator g(3);
  auto p = randperm(500, g);
  Tensor xp = index_select(x, 0, Tensor::from_vector(p, {500}));
  EXPECT_NEAR(fid(x, xp), 0.0, 1e-9);
  // Rank-deficient covariance (fewer rows than D): still 0, no NaN.
  Tensor few = randn({5, 12}, 52);
  EXPECT_NEAR(fid(few, few), 0.0, 1e-10);
  // Symmetric, and positive for different sets.
  Tensor y = add(mul(randn({400, 12}, 53), 1.5), 0.3);
  EXPECT_NEAR(fid(x, y), fid(y, x), 1e-9);
  EXPECT_GT(fid(x, y), 1.0);
}

TEST(EvalMetrics, FrechetDistanceClosedForms) {
  auto stats = [](std::vector<double> mu, std::vector<double> cov) {
    FeatureStatistics s;
    const int64_t D = (int64_t)mu.size();
    s.mean = Tensor::from_vector(mu, {D});
    s.cov = Tensor::from_vector(cov, {D, D});
    return s;
  };
  // Diagonal covariances: |dmu|^2 + sum (sigma1 - sigma2)^2.
  auto a = stats({1, 2, 0, -1}, {4, 0, 0, 0, 0, 1, 0, 0, 0, 0, 9, 0, 0, 0, 0, 0.25});
  auto b = stats({0, 2, 1, -1}, {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 4, 0, 0, 0, 0, 1});
  const double want = 1 + 1 + (2 - 1) * (2 - 1) + 0 + (3 - 2) * (3 - 2) + (0.5 - 1) * (0.5 - 1);
  EXPECT_NEAR(frechet_distance(a, b), want, 1e-12);
  // Non-commuting 2x2: tr sqrt(S1 S2) = sqrt(tr(S1 S2) + 2 sqrt(det S1 det S2)).
  auto c = stats({0.5, -0.5}, {2.0, 0.8, 0.8, 1.0});
  auto d = stats({0.0, 0.0}, {1.0, -0.3, -0.3, 3.0});
  const double tr12 = 2.0 * 1.0 + 0.8 * -0.3 + 0.8 * -0.3 + 1.0 * 3.0;
  const double det1 = 2.0 * 1.0 - 0.64, det2 = 3.0 - 0.09;
  const double want2 = 0.5 + 3.0 + 4.0 - 2.0 * std::sqrt(tr12 + 2.0 * std::sqrt(det1 * det2));
  EXPECT_NEAR(frechet_distance(c, d), want2, 1e-12);
  EXPECT_NEAR(frechet_distance(d, c), want2, 1e-12);
  // float32 statistics are accepted.
  auto c32 = c;
  c32.cov = c.cov.to(DType::f32);
  EXPECT_NEAR(frechet_distance(c32, d), want2, 1e-6);
}

TEST(EvalMetrics, FidOfSampledGaussiansApproachesClosedForm) {
  const int64_t N = 40000;
  Tensor z1 = randn({N, 3}, 61), z2 = randn({N, 3}, 62);
  Tensor s1 = Tensor::from_vector(std::vector<double>{1, 1, 1}, {3}), s2 = Tensor::from_vector(std::vector<double>{2, 1, 0.5}, {3});
  Tensor m1 = Tensor::from_vector(std::vector<double>{1, 0, 0}, {3}), m2 = Tensor::zeros({3}, DType::f64);
  Tensor x1 = add(mul(z1, s1), m1), x2 = add(mul(z2, s2), m2);
  const double want = 1.0 + 1.0 + 0.0 + 0.25;
  EXPECT_NEAR(fid(x1, x2), want, 0.05);
}

TEST(EvalMetrics, MMDist) {
  Tensor t = Tensor::from_vector(std::vector<double>{0, 0, 1, 1, 5, 5}, {3, 2});
  Tensor m = Tensor::from_vector(std::vector<double>{3, 4, 1, 1, 5, 7}, {3, 2});
  EXPECT_DOUBLE_EQ(mm_dist(t, m), (5.0 + 0.0 + 2.0) / 3.0);
  Tensor a = randn({64, 5}, 71), b = randn({64, 5}, 72);
  double s = 0;
  for (int64_t i = 0; i < 64; ++i) s += naive_dist(a, i, b, i);
  EXPECT_NEAR(mm_dist(a.to(DType::f32), b), s / 64.0, 1e-6);
}

TEST(EvalMetrics, SamplePairsAreDistinctAndUniform) {
  Generator g(8);
  auto p = sample_pairs(300, 300, g);
  ASSERT_EQ(p.size(), 300u);
  std::set<int64_t> firsts;
  for (auto [i, j] : p) {
    EXPECT_NE(i, j);
    EXPECT_GE(j, 0);
    EXPECT_LT(j, 300);
    firsts.insert(i);
  }
  EXPECT_EQ(firsts.size(), 300u);  // without replacement
  Generator g2(8);
  EXPECT_EQ(sample_pairs(300, 300, g2), p);
  // n = 3: over many draws every ordered pair (i != j) appears about equally often.
  Generator g3(9);
  std::vector<int> count(9, 0);
  for (int r = 0; r < 3000; ++r)
    for (auto [i, j] : sample_pairs(3, 2, g3)) ++count[i * 3 + j];
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(count[i * 3 + i], 0);
    for (int j = 0; j < 3; ++j)
      if (i != j) {
        EXPECT_NEAR(count[i * 3 + j], 1000, 120) << i << "," << j;
      }
  }
}

TEST(EvalMetrics, DiversityOfKnownPointSets) {
  // Rows c * e_i: every two distinct points are c * sqrt(2) apart.
  Tensor x = mul(Tensor::zeros({320, 320}, DType::f64), 0.0);
  for (int64_t i = 0; i < 320; ++i) x.set({i, i}, 2.0);
  Generator g(10);
  EXPECT_NEAR(diversity(x, g), 2.0 * std::sqrt(2.0), 1e-12);
  // Identical points: 0.
  Generator g2(10);
  EXPECT_EQ(diversity(Tensor::ones({300, 4}), g2), 0.0);
  // Random points: equals the naive mean over the same pairs.
  Tensor y = randn({400, 6}, 81);
  Generator g3(12), g4(12);
  auto pairs = sample_pairs(400, 300, g4);
  double s = 0;
  for (auto [i, j] : pairs) s += naive_dist(y, i, y, j);
  EXPECT_NEAR(diversity(y.to(DType::f32), g3), s / 300.0, 1e-6);
}

TEST(EvalMetrics, MultiModalityOfKnownPointSets) {
  // Prompt p: samples c_p * e_s, so every pair of its distinct samples is c_p * sqrt(2) apart.
  const int64_t P = 100, S = 30;
  Tensor x = Tensor::zeros({P, S, S}, DType::f64);
  double want = 0;
  for (int64_t p = 0; p < P; ++p) {
    const double c = 0.5 + 0.01 * (double)p;
    want += c * std::sqrt(2.0) / (double)P;
    for (int64_t s = 0; s < S; ++s) x.set({p, s, s}, c);
  }
  Generator g(13);
  EXPECT_NEAR(multimodality(x, g), want, 1e-12);
  // Random samples: the naive mean over the same per-prompt draws (in prompt order).
  Tensor y = randn({7, 12, 3}, 91);
  Generator g2(14), g3(14);
  double s = 0;
  for (int64_t p = 0; p < 7; ++p) {
    Tensor yp = y.select(0, p);
    for (auto [i, j] : sample_pairs(12, 10, g3)) s += naive_dist(yp, i, yp, j);
  }
  EXPECT_NEAR(multimodality(y, g2), s / 70.0, 1e-12);
}

TEST(EvalMetrics, MeanAndConfidenceInterval) {
  MeanCI r = mean_ci({1, 2, 3, 4});
  EXPECT_DOUBLE_EQ(r.mean, 2.5);
  EXPECT_DOUBLE_EQ(r.std, std::sqrt(1.25));  // divisor R (numpy default)
  EXPECT_DOUBLE_EQ(r.ci95, 1.96 * std::sqrt(1.25) / 2.0);
  EXPECT_EQ(r.runs, 4);
  MeanCI one = mean_ci({3.5});
  EXPECT_EQ(one.mean, 3.5);
  EXPECT_EQ(one.ci95, 0.0);
  // repeat_runs: run r gets Generator(run_seed(seed, r)); same seed -> same numbers.
  std::vector<uint64_t> seeds;
  auto f = [&](Generator& gen, int run) {
    seeds.push_back(gen.seed());
    return std::vector<double>{(double)run, rand_uniform({1}, gen, 0.0, 1.0, DType::f64).item()};
  };
  auto a = repeat_runs(5, 42, f);
  ASSERT_EQ(a.size(), 2u);
  EXPECT_DOUBLE_EQ(a[0].mean, 2.0);
  EXPECT_DOUBLE_EQ(a[0].ci95, 1.96 * std::sqrt(2.0) / std::sqrt(5.0));
  for (int r = 0; r < 5; ++r) EXPECT_EQ(seeds[r], run_seed(42, r));
  EXPECT_EQ(std::set<uint64_t>(seeds.begin(), seeds.end()).size(), 5u);
  auto b = repeat_runs(5, 42, f);
  EXPECT_EQ(a[1].mean, b[1].mean);
  auto c = repeat_runs(5, 43, f);
  EXPECT_NE(a[1].mean, c[1].mean);
}

TEST(EvalMetrics, BadInputThrows) {
  Tensor x = randn({40, 4}, 1), y3 = randn({40, 3}, 2);
  Generator g(1);
  expect_error([&] { euclidean_distance_matrix(x, y3); }, {"euclidean_distance_matrix", "[40, 4]", "[40, 3]"});
  expect_error([&] { euclidean_distance_matrix(Tensor::zeros({4}), x); }, {"euclidean_distance_matrix", "(N, D)", "[4]"});
  expect_error([&] { euclidean_distance_matrix(x, Tensor::zeros({3, 4}, DType::i64)); }, {"b must be", "[3, 4]"});
  expect_error([&] { euclidean_distance_matrix(Tensor(), x); }, {"undefined"});
  expect_error([&] { r_precision(x, randn({39, 4}, 3), g); }, {"r_precision", "[40, 4]", "[39, 4]"});
  expect_error([&] { r_precision(x.slice(0, 0, 20), x.slice(0, 0, 20), g); }, {"r_precision", "fewer than one batch of 32"});
  expect_error([&] { r_precision(x, x, g, 0); }, {"r_precision", "top_k", "got 0"});
  expect_error([&] { r_precision(x, x, g, 33); }, {"top_k", "got 33"});
  expect_error([&] { r_precision(x, x, g, 1, 1); }, {"batch_size must be >= 2"});
  expect_error([&] { r_precision(Tensor::zeros({0, 4}), Tensor::zeros({0, 4}), g); }, {"r_precision", "empty", "[0, 4]"});
  expect_error([&] { shuffled_r_precision(x, y3, g); }, {"shuffled_r_precision", "[40, 3]"});
  expect_error([&] { fid(x, y3); }, {"fid", "differ in D"});
  expect_error([&] { fid(x.slice(0, 0, 1), x); }, {"fid", "at least 2 rows", "[1, 4]"});
  expect_error([&] { feature_statistics(randn({2, 2, 2}, 1)); }, {"feature_statistics", "[2, 2, 2]"});
  FeatureStatistics bad = feature_statistics(x);
  bad.cov = Tensor::zeros({4, 3}, DType::f64);
  expect_error([&] { frechet_distance(bad, feature_statistics(x)); }, {"frechet_distance", "[4, 3]"});
  bad.mean = Tensor::zeros({0}, DType::f64);
  bad.cov = Tensor::zeros({0, 0}, DType::f64);
  expect_error([&] { frechet_distance(bad, bad); }, {"frechet_distance", "D >= 1", "[0]"});
  expect_error([&] { frechet_distance(feature_statistics(x), feature_statistics(y3)); }, {"frechet_distance", "dimensions differ"});
  expect_error([&] { mm_dist(x, y3); }, {"mm_dist", "[40, 4]", "[40, 3]"});
  expect_error([&] { diversity(x, g); }, {"diversity", "[40, 4]", "pairs = 300"});
  expect_error([&] { diversity(x.slice(0, 0, 1), g, 1); }, {"diversity", "[1, 4]"});
  expect_error([&] { multimodality(x, g); }, {"multimodality", "(P, S, D)", "[40, 4]"});
  expect_error([&] { multimodality(randn({3, 5, 2}, 1), g); }, {"multimodality", "[3, 5, 2]", "pairs = 10"});
  expect_error([&] { sample_pairs(1, 1, g); }, {"sample_pairs", "n = 1"});
  expect_error([&] { sample_pairs(5, 6, g); }, {"sample_pairs", "got 6"});
  expect_error([&] { mean_pair_distance(x, {{0, 40}}); }, {"mean_pair_distance", "(0, 40)", "[40, 4]"});
  expect_error([&] { mean_ci({}); }, {"mean_ci"});
  expect_error([&] { repeat_runs(0, 1, [](Generator&, int) { return std::vector<double>{1}; }); }, {"repeat_runs", "got 0"});
  expect_error([&] { repeat_runs(3, 1, [](Generator&, int r) { return std::vector<double>(r == 2 ? 1 : 2, 0.0); }); },
               {"repeat_runs", "run 2 returned 1 values, expected 2"});
}
