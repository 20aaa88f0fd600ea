// test_fused_util.h — helpers shared by the tests/test_fused_*.cpp programs: seeded random vectors, central
// finite differences in double, tolerance comparisons and float<->double conversion.
#pragma once
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <vector>

namespace fused_test {

using Vec = std::vector<double>;

inline Vec randn(size_t n, uint64_t seed, double scale = 1.0) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> nd(0.0, scale);
  Vec v(n);
  for (auto& x : v) x = nd(rng);
  return v;
}

inline std::vector<float> to_float(const Vec& v) { return std::vector<float>(v.begin(), v.end()); }
inline Vec to_double(const std::vector<float>& v) { return Vec(v.begin(), v.end()); }

inline double dot(const Vec& a, const Vec& b) {
  double s = 0;
  for (size_t i = 0; i < a.size(); ++i) s += a[i] * b[i];
  return s;
}

// d loss / d x[i] by central differences, loss() reading x. x is restored afterwards.
inline Vec numeric_grad(Vec& x, const std::function<double()>& loss, double eps = 1e-6) {
  Vec g(x.size());
  for (size_t i = 0; i < x.size(); ++i) {
    const double x0 = x[i];
    x[i] = x0 + eps;
    const double lp = loss();
    x[i] = x0 - eps;
    const double lm = loss();
    x[i] = x0;
    g[i] = (lp - lm) / (2 * eps);
  }
  return g;
}

// |a - b| <= atol + rtol * |b| element-wise, reporting the first offenders.
inline void expect_close(const Vec& a, const Vec& b, double atol, double rtol, const std::string& what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  int bad = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    const double tol = atol + rtol * std::fabs(b[i]);
    if (!(std::fabs(a[i] - b[i]) <= tol)) {
      if (++bad <= 5) ADD_FAILURE() << what << "[" << i << "]: got " << a[i] << " want " << b[i];
    }
  }
  EXPECT_EQ(bad, 0) << what << ": " << bad << " of " << a.size() << " elements out of tolerance";
}

// Float result against the double one, relative to max(1, largest magnitude of the double result): values that
// are zero up to cancellation (e.g. normalising a single element) carry float rounding of the O(1) inputs.
inline void expect_float_matches(const std::vector<float>& f, const Vec& d, double rel, const std::string& what) {
  double mx = 1.0;
  for (double x : d) mx = std::max(mx, std::fabs(x));
  expect_close(to_double(f), d, rel * mx, rel, what);
}

inline bool bitwise_equal(const std::vector<float>& a, const std::vector<float>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (std::memcmp(&a[i], &b[i], sizeof(float)) != 0) return false;
  return true;
}

}  // namespace fused_test
