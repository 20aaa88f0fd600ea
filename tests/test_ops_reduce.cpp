// test_ops_reduce.cpp — sum/mean/amax/amin/logsumexp/max/argmax/sum_to against naive double loops over every
// dim subset, layout, dtype, keepdim, size-1 and size-0 dims; thread-count invariance; errors.
#include <cmath>
#include <limits>

#include "test_tensor_util.h"
#include "tensor/parallel.h"

using namespace t2m;
using namespace t2m::testing;

namespace {

// Naive reduction over `dims` (already non-negative) with f(acc, x); out shape per keepdim.
std::vector<double> ref_reduce(const Tensor& a, const std::vector<int64_t>& dims, double init,
                               const std::function<double(double, double)>& f, Shape& out_shape, bool keepdim) {
  std::vector<bool> red(a.dim(), false);
  for (int64_t d : dims) red[d] = true;
  Shape kept;
  out_shape.clear();
  for (int64_t d = 0; d < a.dim(); ++d) {
    if (!red[d]) kept.push_back(a.shape()[d]);
    if (!red[d]) out_shape.push_back(a.shape()[d]);
    else if (keepdim) out_shape.push_back(1);
  }
  std::vector<double> out(shape_numel(kept), init);
  for_each_index(a.shape(), [&](const std::vector<int64_t>& i) {
    int64_t o = 0;
    for (int64_t d = 0; d < a.dim(); ++d)
      if (!red[d]) o = o * a.shape()[d] + i[d];
    out[o] = f(out[o], raw_get(a, i));
  });
  return out;
}

std::vector<std::vector<int64_t>> subsets(int64_t nd) {
  std::vector<std::vector<int64_t>> r;
  for (int64_t m = 1; m < (1 << nd); ++m) {
    std::vector<int64_t> s;
    for (int64_t d = 0; d < nd; ++d)
      if (m & (1 << d)) s.push_back(d);
    r.push_back(s);
  }
  return r;
}

}  // namespace

TEST(OpsReduce, SumMeanAmaxAminEverySubset) {
  uint32_t seed = 1;
  for (DType dt : {DType::f32, DType::f64})
    for (const Shape& s : std::vector<Shape>{{3, 4, 5}, {2, 1, 20}, {1, 17}, {6, 0, 2}}) {
      Tensor a0 = random_tensor(s, dt, seed++);
      for (const Tensor& a : layouts(a0))
        for (bool keep : {false, true})
          for (const auto& dims : subsets(a.dim())) {
            Shape os;
            const std::string what = shape_str(s) + " dims " + shape_str(dims) + (keep ? " keep" : "");
            auto ws = ref_reduce(a0, dims, 0.0, [](double x, double y) { return x + y; }, os, keep);
            expect_values(sum(a, dims, keep), os, ws, tol_for(dt) * 4, "sum " + what);
            const double n = (double)(a0.numel() ? a0.numel() / std::max<int64_t>(1, shape_numel(os)) : 0);
            std::vector<double> wm;
            int64_t nred = 1;
            for (int64_t d : dims) nred *= s[d];
            for (double v : ws) wm.push_back(nred ? v / (double)nred : std::nan(""));
            (void)n;
            expect_values(mean(a, dims, keep), os, wm, tol_for(dt) * 4, "mean " + what);
            if (nred == 0) {
              if (shape_numel(os) > 0) expect_error([&] { amax(a, dims, keep); }, {"amax", "empty"});
              continue;
            }
            auto wx = ref_reduce(a0, dims, -1e300, [](double x, double y) { return std::max(x, y); }, os, keep);
            expect_values(amax(a, dims, keep), os, wx, 0, "amax " + what);
            auto wn = ref_reduce(a0, dims, 1e300, [](double x, double y) { return std::min(x, y); }, os, keep);
            expect_values(amin(a, dims, keep), os, wn, 0, "amin " + what);
          }
    }
}

TEST(OpsReduce, AllDimsAndNegativeDims) {
  Tensor a = random_tensor({4, 5}, DType::f64, 3);
  double tot = 0;
  for (double v : raw_values(a)) tot += v;
  Tensor s = sum(a);
  EXPECT_EQ(s.dim(), 0);
  EXPECT_NEAR(s.item(), tot, 1e-12);
  EXPECT_EQ(shape_str(sum(a, {}, true).shape()), "[1, 1]");
  EXPECT_NEAR(mean(a).item(), tot / 20, 1e-12);
  expect_values(sum(a, {-1}), {4}, raw_values(sum(a, {1})), 0);
  EXPECT_EQ(sum(Tensor::zeros({0, 3})).item(), 0.0);
  EXPECT_EQ(sum(Tensor::scalar(2.5)).item(), 2.5);
}

TEST(OpsReduce, BroadcastExpandedInput) {
  Tensor row = random_tensor({1, 7}, DType::f32, 4);
  Tensor e = row.expand({50, 7});
  std::vector<double> want;
  for (double v : raw_values(row)) want.push_back(50 * v);
  expect_values(sum(e, {0}), {7}, want, 1e-6);
  expect_values(amax(e, {0}), {7}, raw_values(row), 0);
}

TEST(OpsReduce, LargeSumsAccurateAndThreadInvariant) {
  // Columns (column pass), rows (block pass with several blocks) and a full sum, at 1 and 2 threads.
  const int saved = get_num_threads();
  Tensor a = random_tensor({3000, 40}, DType::f32, 5, 0.0, 1.0);
  Tensor big = random_tensor({100003}, DType::f32, 6, 0.0, 1.0);
  std::vector<std::vector<double>> r[2];
  for (int t : {1, 2}) {
    set_num_threads(t);
    r[t - 1] = {raw_values(sum(a, {0})), raw_values(sum(a, {1})), raw_values(sum(big)),
                raw_values(sum(a.transpose(0, 1), {1})), raw_values(amax(a, {0}))};
  }
  set_num_threads(saved);
  for (size_t k = 0; k < r[0].size(); ++k) EXPECT_EQ(r[0][k], r[1][k]) << k;
  double tot = 0;
  for (double v : raw_values(big)) tot += v;
  // Accumulated in double: only the final rounding to float remains (half an ulp of ~5e4 is ~2e-3).
  EXPECT_NEAR(r[0][2][0], tot, 2.5e-3);
  Shape os;
  expect_values(sum(a, {0}), {40}, ref_reduce(a, {0}, 0, [](double x, double y) { return x + y; }, os, false), 1e-6);
}

TEST(OpsReduce, LogSumExp) {
  for (DType dt : {DType::f32, DType::f64}) {
    Tensor a0 = random_tensor({3, 6}, dt, 8, -5, 5);
    for (const Tensor& a : layouts(a0))
      for (int64_t d : {0, 1, -1})
        for (bool keep : {false, true}) {
          const int64_t dd = d < 0 ? d + 2 : d;
          Shape os;
          auto w = ref_reduce(a0, {dd}, 0, [](double acc, double x) { return acc + std::exp(x); }, os, keep);
          for (double& v : w) v = std::log(v);
          expect_values(logsumexp(a, d, keep), os, w, tol_for(dt) * 4);
        }
    // Stable for huge values and all -inf rows.
    const double inf = std::numeric_limits<double>::infinity();
    Tensor h = Tensor::from_vector(std::vector<double>{1000, 1000, -inf, -inf, 0, -inf}, {3, 2}).to(dt);
    expect_values(logsumexp(h, 1), {3}, {1000 + std::log(2.0), -inf, 0}, tol_for(dt));
    expect_values(logsumexp(Tensor::zeros({2, 0}, dt), 1), {2}, {-inf, -inf}, 0);
  }
}

TEST(OpsReduce, MaxArgmaxFirstWins) {
  Tensor a = Tensor::from_vector(std::vector<float>{1, 3, 3, 2, 5, 5, 5, 0, -1}, {3, 3});
  MaxResult m = max(a, 1);
  expect_values(m.values, {3}, {3, 5, 5}, 0);
  expect_values(m.indices, {3}, {1, 1, 0}, 0);
  EXPECT_EQ(m.indices.dtype(), DType::i64);
  expect_values(argmax(a, 0, true), {1, 3}, {2, 1, 1}, 0);
  for (DType dt : {DType::f32, DType::f64}) {
    Tensor b0 = random_tensor({4, 7, 3}, dt, 9);
    for (const Tensor& b : layouts(b0))
      for (int64_t d = 0; d < 3; ++d) {
        MaxResult r = max(b, d, true);
        Shape os = b0.shape();
        os[d] = 1;
        std::vector<double> wv, wi;
        for_each_index(os, [&](const std::vector<int64_t>& i) {
          double best = -1e300;
          int64_t bi = -1;
          auto j = i;
          for (int64_t k = 0; k < b0.shape()[d]; ++k) {
            j[d] = k;
            if (raw_get(b0, j) > best) best = raw_get(b0, j), bi = k;
          }
          wv.push_back(best);
          wi.push_back((double)bi);
        });
        expect_values(r.values, os, wv, 0);
        expect_values(r.indices, os, wi, 0);
      }
  }
  const double nan = std::nan("");
  Tensor n = Tensor::from_vector(std::vector<double>{1, nan, 5, nan}, {4});
  EXPECT_EQ(argmax(n, 0).item(), 1.0);
  EXPECT_TRUE(std::isnan(amax(n).item()));
  expect_error([&] { max(Tensor::zeros({2, 0}), 1); }, {"max", "[2, 0]"});
}

TEST(OpsReduce, SumTo) {
  for (DType dt : {DType::f32, DType::f64}) {
    Tensor g0 = random_tensor({2, 3, 4}, dt, 10);
    for (const Tensor& g : layouts(g0)) {
      Shape os;
      auto w = ref_reduce(g0, {0, 2}, 0, [](double x, double y) { return x + y; }, os, false);
      expect_values(sum_to(g, {3, 1}), {3, 1}, w, tol_for(dt) * 4);
      w = ref_reduce(g0, {0}, 0, [](double x, double y) { return x + y; }, os, false);
      expect_values(sum_to(g, {3, 4}), {3, 4}, w, tol_for(dt) * 4);
      w = ref_reduce(g0, {0, 1, 2}, 0, [](double x, double y) { return x + y; }, os, false);
      expect_values(sum_to(g, {}), {}, w, tol_for(dt) * 4);
      Tensor same = sum_to(g, {2, 3, 4});
      EXPECT_FALSE(same.shares_storage(g));
      expect_values(same, {2, 3, 4}, raw_values(g0), 0);
    }
  }
  expect_error([&] { sum_to(Tensor::zeros({2, 3}), {4}); }, {"sum_to", "[2, 3]", "[4]"});
  expect_error([&] { sum_to(Tensor::zeros({3}), {2, 3}); }, {"sum_to", "[3]", "[2, 3]"});
}

TEST(OpsReduce, Errors) {
  Tensor a = Tensor::zeros({2, 3});
  expect_error([&] { sum(a, {2}); }, {"sum", "2"});
  expect_error([&] { mean(a, {0, -2}); }, {"mean", "repeated", "[2, 3]"});
  expect_error([&] { amin(Tensor::zeros({0})); }, {"amin", "[0]"});
  expect_error([&] { sum(Tensor::zeros({2}, DType::i64)); }, {"sum", "i64"});
  expect_error([&] { logsumexp(a, 5); }, {"logsumexp", "5"});
}
