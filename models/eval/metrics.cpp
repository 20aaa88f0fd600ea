// metrics.cpp — R-precision, FID, MM-Dist, Diversity, MultiModality and the mean +- 95% CI runner, in float64.
#include "models/eval/metrics.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "tensor/parallel.h"

namespace t2m::eval {

namespace {

using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

std::string describe(const Tensor& t) {
  if (!t.defined()) return "an undefined tensor";
  return std::string(dtype_name(t.dtype())) + " " + shape_str(t.shape());
}

// Checks a float tensor of rank `rank` with no empty dimension; returns a contiguous float64 copy/view.
Tensor as_float64(const Tensor& t, int64_t rank, const char* op, const char* what) {
  const char* want = rank == 2 ? "(N, D)" : "(P, S, D)";
  if (!t.defined() || (t.dtype() != DType::f32 && t.dtype() != DType::f64) || t.dim() != rank)
    throw Error(std::string(op) + ": " + what + " must be a float32/float64 " + want + " tensor, got " +
                describe(t));
  for (int64_t d = 0; d < rank; ++d)
    if (t.size(d) == 0) throw Error(std::string(op) + ": " + what + " is empty " + shape_str(t.shape()));
  return t.to(DType::f64).contiguous();
}

// d = ||a - b||_2 over D entries.
double distance(const double* a, const double* b, int64_t D) {
  double s = 0.0;
  for (int64_t k = 0; k < D; ++k) {
    const double d = a[k] - b[k];
    s += d * d;
  }
  return std::sqrt(s);
}

void check_pairs_shape(const Tensor& text, const Tensor& motion, const char* op) {
  if (text.shape() != motion.shape())
    throw Error(std::string(op) + ": text " + shape_str(text.shape()) + " and motion " +
                shape_str(motion.shape()) + " must have the same (N, D) (row i of each is a matched pair)");
}

// Square roots of the eigenvalues of a symmetric PSD matrix; eigenvalues below D * eps * max|l| are rounding
// noise of a (numerically) singular matrix and count as 0 (their square roots would be ~1e-8, not ~1e-16).
Eigen::VectorXd sqrt_eigenvalues(const Eigen::VectorXd& l) {
  const double cut = (double)l.size() * std::numeric_limits<double>::epsilon() * l.cwiseAbs().maxCoeff();
  return l.unaryExpr([cut](double v) { return v > cut ? std::sqrt(v) : 0.0; });
}

// Symmetric PSD square root A^1/2 = V diag(sqrt(l)) V^T.
Eigen::MatrixXd sqrt_psd(const Eigen::MatrixXd& a) {
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(a);
  if (es.info() != Eigen::Success) throw Error("fid: eigen decomposition failed (non-finite covariance?)");
  return es.eigenvectors() * sqrt_eigenvalues(es.eigenvalues()).asDiagonal() * es.eigenvectors().transpose();
}

uint64_t splitmix64(uint64_t z) {
  z += 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

}  // namespace

// (N, D) x (M, D) -> (N, M): d_ij = ||a_i - b_j||_2.
Tensor euclidean_distance_matrix(const Tensor& a, const Tensor& b) {
  const char* op = "euclidean_distance_matrix";
  Tensor A = as_float64(a, 2, op, "a"), B = as_float64(b, 2, op, "b");
  if (A.size(1) != B.size(1))
    throw Error(std::string(op) + ": a " + shape_str(a.shape()) + " and b " + shape_str(b.shape()) +
                " differ in D");
  const int64_t N = A.size(0), M = B.size(0), D = A.size(1);
  Tensor out = Tensor::empty({N, M}, DType::f64);
  const double* pa = A.data<double>();
  const double* pb = B.data<double>();
  double* po = out.data<double>();
#pragma omp parallel for schedule(static) num_threads(get_num_threads()) if (N * M * D >= kParallelGrain)
  for (int64_t i = 0; i < N; ++i)
    for (int64_t j = 0; j < M; ++j) po[i * M + j] = distance(pa + i * D, pb + j * D, D);
  return out;
}

RPrecision r_precision(const Tensor& text, const Tensor& motion, Generator& gen, int top_k, int64_t batch_size) {
  const char* op = "r_precision";
  Tensor T = as_float64(text, 2, op, "text"), M = as_float64(motion, 2, op, "motion");
  check_pairs_shape(text, motion, op);
  if (batch_size < 2) throw Error(std::string(op) + ": batch_size must be >= 2, got " + std::to_string(batch_size));
  if (top_k < 1 || top_k > batch_size)
    throw Error(std::string(op) + ": top_k must be in [1, batch_size = " + std::to_string(batch_size) + "], got " +
                std::to_string(top_k));
  const int64_t N = T.size(0), D = T.size(1), bs = batch_size;
  if (N < bs)
    throw Error(std::string(op) + ": " + std::to_string(N) + " pairs " + shape_str(text.shape()) +
                " are fewer than one batch of " + std::to_string(bs));
  const std::vector<int64_t> perm = randperm(N, gen);
  RPrecision r;
  r.batches = N / bs;
  r.samples = r.batches * bs;
  std::vector<int64_t> hits((size_t)top_k, 0);
  const double* pt = T.data<double>();
  const double* pm = M.data<double>();
  for (int64_t b = 0; b < r.batches; ++b) {
    const int64_t* idx = perm.data() + b * bs;
    for (int64_t i = 0; i < bs; ++i) {
      const double* t = pt + idx[i] * D;
      const double dii = distance(t, pm + idx[i] * D, D);
      int64_t rank = 0;  // other motions at least as close as the true one (ties count against it)
      for (int64_t j = 0; j < bs; ++j)
        if (j != i && distance(t, pm + idx[j] * D, D) <= dii) ++rank;
      for (int64_t k = rank; k < top_k; ++k) ++hits[(size_t)k];
    }
  }
  for (int k = 0; k < top_k; ++k) r.top.push_back((double)hits[(size_t)k] / (double)r.samples);
  return r;
}

RPrecision shuffled_r_precision(const Tensor& text, const Tensor& motion, Generator& gen, int top_k,
                                int64_t batch_size) {
  Tensor T = as_float64(text, 2, "shuffled_r_precision", "text");
  check_pairs_shape(text, motion, "shuffled_r_precision");
  const int64_t N = T.size(0), D = T.size(1);
  const std::vector<int64_t> perm = randperm(N, gen);
  Tensor S = Tensor::empty({N, D}, DType::f64);
  for (int64_t i = 0; i < N; ++i)
    std::copy_n(T.data<double>() + perm[(size_t)i] * D, D, S.data<double>() + i * D);
  return r_precision(S, motion, gen, top_k, batch_size);
}

FeatureStatistics feature_statistics(const Tensor& x) {
  Tensor X = as_float64(x, 2, "feature_statistics", "x");
  const int64_t N = X.size(0), D = X.size(1);
  if (N < 2)
    throw Error("feature_statistics: need at least 2 rows for a covariance, got " + shape_str(x.shape()));
  Eigen::Map<const RowMatrix> m(X.data<double>(), N, D);
  Eigen::RowVectorXd mu = m.colwise().mean();
  RowMatrix c = m.rowwise() - mu;
  RowMatrix cov = (c.transpose() * c) / (double)(N - 1);
  FeatureStatistics s;
  s.n = N;
  s.mean = Tensor::empty({D}, DType::f64);
  s.cov = Tensor::empty({D, D}, DType::f64);
  std::copy_n(mu.data(), D, s.mean.data<double>());
  std::copy_n(cov.data(), D * D, s.cov.data<double>());
  return s;
}

// FID = ||mu1 - mu2||^2 + tr S1 + tr S2 - 2 tr sqrt(S1^1/2 S2 S1^1/2).
double frechet_distance(const FeatureStatistics& a, const FeatureStatistics& b) {
  const char* op = "frechet_distance";
  auto check = [&](const FeatureStatistics& s, const char* which) {
    if (!s.mean.defined() || !s.cov.defined() || s.mean.dim() != 1 || s.cov.dim() != 2 ||
        s.mean.size(0) < 1 || s.cov.size(0) != s.mean.size(0) || s.cov.size(1) != s.mean.size(0) ||
        s.mean.dtype() == DType::i64 ||
        s.cov.dtype() == DType::i64)
      throw Error(std::string(op) + ": statistics " + which + " need a float mean (D,) and cov (D, D), D >= 1, got mean " +
                  describe(s.mean) + " and cov " + describe(s.cov));
  };
  check(a, "a");
  check(b, "b");
  const int64_t D = a.mean.size(0);
  if (b.mean.size(0) != D)
    throw Error(std::string(op) + ": dimensions differ, mean " + shape_str(a.mean.shape()) + " vs " +
                shape_str(b.mean.shape()));
  Tensor m1 = a.mean.to(DType::f64).contiguous(), m2 = b.mean.to(DType::f64).contiguous();
  Tensor c1 = a.cov.to(DType::f64).contiguous(), c2 = b.cov.to(DType::f64).contiguous();
  Eigen::Map<const Eigen::VectorXd> mu1(m1.data<double>(), D), mu2(m2.data<double>(), D);
  Eigen::MatrixXd S1 = Eigen::Map<const RowMatrix>(c1.data<double>(), D, D);
  Eigen::MatrixXd S2 = Eigen::Map<const RowMatrix>(c2.data<double>(), D, D);
  S1 = 0.5 * (S1 + S1.transpose());
  S2 = 0.5 * (S2 + S2.transpose());
  Eigen::MatrixXd r1 = sqrt_psd(S1);
  Eigen::MatrixXd inner = r1 * S2 * r1;
  inner = 0.5 * (inner + inner.transpose());
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(inner, Eigen::EigenvaluesOnly);
  if (es.info() != Eigen::Success) throw Error(std::string(op) + ": eigen decomposition failed");
  const double tr_sqrt = sqrt_eigenvalues(es.eigenvalues()).sum();
  return (mu1 - mu2).squaredNorm() + S1.trace() + S2.trace() - 2.0 * tr_sqrt;
}

double fid(const Tensor& a, const Tensor& b) {
  Tensor A = as_float64(a, 2, "fid", "a"), B = as_float64(b, 2, "fid", "b");
  if (A.size(1) != B.size(1))
    throw Error("fid: a " + shape_str(a.shape()) + " and b " + shape_str(b.shape()) + " differ in D");
  if (A.size(0) < 2 || B.size(0) < 2)
    throw Error("fid: each set needs at least 2 rows, got a " + shape_str(a.shape()) + " and b " +
                shape_str(b.shape()));
  return frechet_distance(feature_statistics(A), feature_statistics(B));
}

double mm_dist(const Tensor& text, const Tensor& motion) {
  Tensor T = as_float64(text, 2, "mm_dist", "text"), M = as_float64(motion, 2, "mm_dist", "motion");
  check_pairs_shape(text, motion, "mm_dist");
  const int64_t N = T.size(0), D = T.size(1);
  double s = 0.0;
  for (int64_t i = 0; i < N; ++i) s += distance(T.data<double>() + i * D, M.data<double>() + i * D, D);
  return s / (double)N;
}

std::vector<std::pair<int64_t, int64_t>> sample_pairs(int64_t n, int64_t count, Generator& gen) {
  if (n < 2) throw Error("sample_pairs: need at least 2 samples, got n = " + std::to_string(n));
  if (count < 1 || count > n)
    throw Error("sample_pairs: count must be in [1, n = " + std::to_string(n) + "], got " + std::to_string(count));
  const std::vector<int64_t> first = randperm(n, gen);
  const std::vector<int64_t> off = randint({count}, gen, 0, n - 1).to_vector<int64_t>();
  std::vector<std::pair<int64_t, int64_t>> out((size_t)count);
  for (int64_t k = 0; k < count; ++k) {
    const int64_t i = first[(size_t)k];
    out[(size_t)k] = {i, (i + 1 + off[(size_t)k]) % n};
  }
  return out;
}

double mean_pair_distance(const Tensor& x, const std::vector<std::pair<int64_t, int64_t>>& pairs) {
  Tensor X = as_float64(x, 2, "mean_pair_distance", "x");
  const int64_t N = X.size(0), D = X.size(1);
  if (pairs.empty()) throw Error("mean_pair_distance: no pairs");
  double s = 0.0;
  for (auto [i, j] : pairs) {
    if (i < 0 || i >= N || j < 0 || j >= N)
      throw Error("mean_pair_distance: pair (" + std::to_string(i) + ", " + std::to_string(j) +
                  ") out of range for x " + shape_str(x.shape()));
    s += distance(X.data<double>() + i * D, X.data<double>() + j * D, D);
  }
  return s / (double)pairs.size();
}

double diversity(const Tensor& motion, Generator& gen, int64_t pairs) {
  Tensor X = as_float64(motion, 2, "diversity", "motion");
  const int64_t N = X.size(0);
  if (N < 2 || pairs < 1 || pairs > N)
    throw Error("diversity: need 2 <= N and 1 <= pairs <= N (distinct first samples), got motion " +
                shape_str(motion.shape()) + " and pairs = " + std::to_string(pairs));
  return mean_pair_distance(X, sample_pairs(N, pairs, gen));
}

double multimodality(const Tensor& motion, Generator& gen, int64_t pairs) {
  Tensor X = as_float64(motion, 3, "multimodality", "motion");
  const int64_t P = X.size(0), S = X.size(1), D = X.size(2);
  if (S < 2 || pairs < 1 || pairs > S)
    throw Error("multimodality: need 2 <= S and 1 <= pairs <= S samples per prompt, got motion " +
                shape_str(motion.shape()) + " (P, S, D) and pairs = " + std::to_string(pairs));
  double s = 0.0;
  for (int64_t p = 0; p < P; ++p) {
    const double* base = X.data<double>() + p * S * D;
    for (auto [i, j] : sample_pairs(S, pairs, gen)) s += distance(base + i * D, base + j * D, D);
  }
  return s / (double)(P * pairs);
}

MeanCI mean_ci(const std::vector<double>& values) {
  if (values.empty()) throw Error("mean_ci: no values");
  MeanCI r;
  r.runs = (int)values.size();
  for (double v : values) r.mean += v;
  r.mean /= (double)r.runs;
  double ss = 0.0;
  for (double v : values) ss += (v - r.mean) * (v - r.mean);
  r.std = std::sqrt(ss / (double)r.runs);
  r.ci95 = 1.96 * r.std / std::sqrt((double)r.runs);
  return r;
}

uint64_t run_seed(uint64_t seed, int run) { return splitmix64(splitmix64(seed) ^ (uint64_t)(int64_t)run); }

std::vector<MeanCI> repeat_runs(int runs, uint64_t seed,
                                const std::function<std::vector<double>(Generator& gen, int run)>& f) {
  if (runs < 1) throw Error("repeat_runs: runs must be >= 1, got " + std::to_string(runs));
  std::vector<std::vector<double>> per_metric;
  for (int r = 0; r < runs; ++r) {
    Generator gen(run_seed(seed, r));
    std::vector<double> v = f(gen, r);
    if (r == 0) per_metric.resize(v.size());
    if (v.empty() || v.size() != per_metric.size())
      throw Error("repeat_runs: run " + std::to_string(r) + " returned " + std::to_string(v.size()) +
                  " values, expected " + (r == 0 ? std::string("at least 1") : std::to_string(per_metric.size())));
    for (size_t m = 0; m < v.size(); ++m) per_metric[m].push_back(v[m]);
  }
  std::vector<MeanCI> out;
  for (const auto& v : per_metric) out.push_back(mean_ci(v));
  return out;
}

}  // namespace t2m::eval
