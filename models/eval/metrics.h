// metrics.h — text-to-motion evaluation metrics on embedding matrices (Guo et al. 2022 protocol, as used by the
// Text2BFM paper's Tables 1-5 and ARCHITECTURE.md section 6). Pure functions: no model, no I/O.
//
// Inputs are embedding matrices Tensor (N, D), float32 or float64, any strides; rows are samples. Everything is
// computed in float64. Row i of a text matrix and row i of a motion matrix are a matched (caption, motion) pair.
// Randomness (batch shuffles, pair draws) comes only from the Generator passed in: same seed, same result.
//
//   euclidean_distance_matrix  d_ij = ||a_i - b_j||_2, (N, D) x (M, D) -> (N, M) float64, summed directly (no
//                              Gram-matrix cancellation: equal rows give exactly 0).
//   r_precision                rows are shuffled by randperm(N, gen) and cut into floor(N / batch_size) batches
//                              of batch_size consecutive rows of the permutation (the remainder is dropped, as in
//                              Guo et al.); in each batch every text ranks the batch's motions by distance. Ties
//                              count against the true motion: its rank is #{j != i : d_ij <= d_ii}, and top-k hits
//                              when that rank is < k. Result: top[k-1] = hit rate over all texts of all batches.
//                              With 1 true + 31 others and unrelated embeddings the expectation is k / 32.
//   shuffled_r_precision       the caption-shuffled control: r_precision after permuting the text rows with a
//                              random permutation (randperm(N, gen) first): must fall to chance.
//   feature_statistics / fid   mean and covariance (unbiased, N - 1) of each set;
//                              FID = ||mu1 - mu2||^2 + tr S1 + tr S2 - 2 tr sqrt(S1^1/2 S2 S1^1/2), both square
//                              roots through Eigen's SelfAdjointEigenSolver; eigenvalues below D * eps * max|l|
//                              (rounding noise, also negative ones) count as 0, so a singular covariance (N <= D)
//                              gives FID(x, x) ~ 1e-15 instead of ~1e-7. The symmetric form has the same trace as
//                              sqrt(S1 S2).
//   mm_dist                    MultiModal Distance: mean_i ||t_i - m_i|| over all N matched pairs (Guo et al.
//                              average it over the R-precision batches, i.e. without the dropped remainder).
//   sample_pairs               `count` index pairs (i, j) in [0, n)^2 with i != j: the i are distinct (the first
//                              count entries of randperm(n, gen)), each j uniform over [0, n) \ {i}
//                              (j = (i + 1 + randint[0, n - 1)) mod n). Guo et al. draw j without that
//                              constraint, so a sample can pair with itself (distance 0, probability ~1/n per
//                              pair); we exclude it so Diversity estimates the mean distance of distinct samples.
//   diversity                  mean distance over sample_pairs(N, pairs = 300) of one motion set.
//   multimodality              motions (P, S, D): P prompts x S samples per prompt; per prompt
//                              sample_pairs(S, pairs = 10) (the P draws in prompt order from one gen); the mean of
//                              all P * pairs distances. Protocol: P = 100, S = 30, pairs = 10.
//   mean_ci / repeat_runs      mean and 95% confidence half-width 1.96 * std / sqrt(R) over R runs, std with
//                              divisor R (numpy's default, as Guo et al.'s get_metric_statistics). repeat_runs
//                              calls f(gen, r) for r = 0..R-1 with gen = Generator(run_seed(seed, r)); f returns
//                              one value per metric (every call the same count); the result is one MeanCI per
//                              metric.
// Errors (t2m::Error, message starts with the function name): undefined or non-float tensors, wrong rank, zero
// rows or zero columns, D or N mismatch (both shapes named), batch_size < 2, top_k outside [1, batch_size],
// fewer rows than one batch, fewer than 2 rows for statistics, pairs < 1 or pairs > n, fewer than 2 samples,
// runs < 1, f returning a different number of values than on its first call.
#pragma once
#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "tensor/rng.h"
#include "tensor/tensor.h"

namespace t2m::eval {

Tensor euclidean_distance_matrix(const Tensor& a, const Tensor& b);

struct RPrecision {
  std::vector<double> top;   // top[k-1] = top-k retrieval rate, k = 1..top_k
  int64_t batches = 0;
  int64_t samples = 0;       // texts ranked = batches * batch_size
};
RPrecision r_precision(const Tensor& text, const Tensor& motion, Generator& gen, int top_k = 3,
                       int64_t batch_size = 32);
RPrecision shuffled_r_precision(const Tensor& text, const Tensor& motion, Generator& gen, int top_k = 3,
                                int64_t batch_size = 32);

struct FeatureStatistics {
  Tensor mean;  // (D,) float64
  Tensor cov;   // (D, D) float64, unbiased
  int64_t n = 0;
};
FeatureStatistics feature_statistics(const Tensor& x);
// Frechet distance between N(mean1, cov1) and N(mean2, cov2) (the FID formula above).
double frechet_distance(const FeatureStatistics& a, const FeatureStatistics& b);
double fid(const Tensor& a, const Tensor& b);

double mm_dist(const Tensor& text, const Tensor& motion);

std::vector<std::pair<int64_t, int64_t>> sample_pairs(int64_t n, int64_t count, Generator& gen);
// Mean of ||x_i - x_j|| over the given pairs (indices checked against N).
double mean_pair_distance(const Tensor& x, const std::vector<std::pair<int64_t, int64_t>>& pairs);
double diversity(const Tensor& motion, Generator& gen, int64_t pairs = 300);
double multimodality(const Tensor& motion, Generator& gen, int64_t pairs = 10);

struct MeanCI {
  double mean = 0, std = 0, ci95 = 0;  // ci95: half-width, the interval is mean +- ci95
  int runs = 0;
};
MeanCI mean_ci(const std::vector<double>& values);
// The seed of run r: a splitmix64 mix of (seed, r), so runs draw independent Philox streams.
uint64_t run_seed(uint64_t seed, int run);
std::vector<MeanCI> repeat_runs(int runs, uint64_t seed,
                                const std::function<std::vector<double>(Generator& gen, int run)>& f);

}  // namespace t2m::eval
