// compositional.cpp — Order Accuracy, per-segment MM-Dist and the Eq 20 transition score.
#include "models/eval/compositional.h"

#include <cmath>
#include <string>

#include "models/data/features.h"

namespace t2m::eval {

namespace {

void check_pair(const Tensor& seg, const Tensor& clause) {
  if (!seg.defined() || !clause.defined() || seg.dim() != 2 || seg.shape() != clause.shape() || seg.size(0) < 1)
    throw Error("compositional: segment and clause embeddings must both be (N >= 1, D), got " +
                (seg.defined() ? shape_str(seg.shape()) : std::string("undefined")) + " and " +
                (clause.defined() ? shape_str(clause.shape()) : std::string("undefined")));
}

std::vector<double> rows(const Tensor& x) { return x.to(DType::f64).contiguous().to_vector<double>(); }

}  // namespace

std::vector<int64_t> segment_bounds_uniform(int64_t T, int64_t N) {
  if (N < 1 || T < N)
    throw Error("compositional: need N >= 1 segments of at least one frame, got T " + std::to_string(T) + ", N " +
                std::to_string(N));
  std::vector<int64_t> b;
  for (int64_t n = 0; n <= N; ++n) b.push_back(n * T / N);
  return b;
}

// §4.3: argmax_j cos(seg_i, clause_j) == i for every segment i
bool order_correct(const Tensor& seg, const Tensor& clause) {
  check_pair(seg, clause);
  const int64_t N = seg.size(0), D = seg.size(1);
  const auto s = rows(seg), c = rows(clause);
  std::vector<double> cn(N);
  for (int64_t j = 0; j < N; ++j) {
    double n2 = 0;
    for (int64_t k = 0; k < D; ++k) n2 += c[j * D + k] * c[j * D + k];
    cn[j] = std::sqrt(n2);
  }
  for (int64_t i = 0; i < N; ++i) {
    int64_t best = -1;
    double best_sim = -INFINITY;
    for (int64_t j = 0; j < N; ++j) {
      double dot = 0;
      for (int64_t k = 0; k < D; ++k) dot += s[i * D + k] * c[j * D + k];
      const double sim = cn[j] > 0 ? dot / cn[j] : 0.0;  // |seg_i| is common to all j
      if (sim > best_sim) best_sim = sim, best = j;
    }
    if (best != i) return false;
  }
  return true;
}

double segment_mm_dist(const Tensor& seg, const Tensor& clause) {
  check_pair(seg, clause);
  const int64_t N = seg.size(0), D = seg.size(1);
  const auto s = rows(seg), c = rows(clause);
  double sum = 0;
  for (int64_t i = 0; i < N; ++i) {
    double d2 = 0;
    for (int64_t k = 0; k < D; ++k) d2 += (s[i * D + k] - c[i * D + k]) * (s[i * D + k] - c[i * D + k]);
    sum += std::sqrt(d2);
  }
  return sum / double(N);
}

// Eq 20: 1/(N−1) Σ_i ||s_{i+1} − s_i|| + ||v_{i+1} − v_i|| at the frames b_i − 1, b_i
double transition_score(const std::vector<float>& features, const std::vector<int64_t>& bounds) {
  constexpr int64_t F = data::kFeatureDim;
  if (features.size() % F != 0)
    throw Error("compositional: features must be [T, 257], got " + std::to_string(features.size()) + " values");
  const int64_t T = (int64_t)features.size() / F;
  const int64_t N = (int64_t)bounds.size() - 1;
  if (N < 1 || bounds.front() < 0 || bounds.back() > T)
    throw Error("compositional: bounds must go from >= 0 to <= T = " + std::to_string(T));
  for (int64_t i = 0; i < N; ++i)
    if (bounds[i + 1] <= bounds[i]) throw Error("compositional: bounds must be strictly increasing");
  if (N == 1) return 0.0;
  double sum = 0;
  for (int64_t i = 1; i < N; ++i) {
    const int64_t b = bounds[i];
    const float* a = features.data() + (b - 1) * F;
    const float* c = features.data() + b * F;
    double ds = 0, dv = 0;
    for (int k = data::kFeatLocalPos; k < data::kFeatRot6d; ++k) ds += double(c[k] - a[k]) * double(c[k] - a[k]);
    for (int k = data::kFeatJointVel; k < data::kFeatContact; ++k) {
      const double d = double(c[k] - a[k]) * sim::kCanonicalFps;
      dv += d * d;
    }
    sum += std::sqrt(ds) + std::sqrt(dv);
  }
  return sum / double(N - 1);
}

}  // namespace t2m::eval
