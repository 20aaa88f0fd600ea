// test_features_norm.cpp — mean/std from given clips, std floor, normalise/denormalise, JSON round trip.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <vector>

#include "models/data/features.h"
#include "models/data/features_norm.h"
#include "tensor/tensor.h"
#include "test_features_synthetic.h"

using namespace t2m::data;

TEST(FeaturesNorm, MatchesTwoPassReferenceAndFloors) {
  // dim 3: column 0 varies, column 1 is constant (std floored), column 2 is large.
  std::vector<float> a = {1, 5, 100, 2, 5, 300, 3, 5, 200};
  std::vector<float> b = {4, 5, 400};
  auto s = compute_feature_stats({&a, &b}, 3, 0.25);
  // Reference by hand: column 0 = {1,2,3,4}: mean 2.5, var 1.25; column 2 = {100,300,200,400}: mean 250,
  // var 12500.
  EXPECT_NEAR(s.mean[0], 2.5, 1e-6);
  EXPECT_NEAR(s.std[0], std::sqrt(1.25), 1e-6);
  EXPECT_NEAR(s.mean[1], 5.0, 1e-6);
  EXPECT_EQ(s.std[1], 0.25f);
  EXPECT_NEAR(s.mean[2], 250.0, 1e-4);
  EXPECT_NEAR(s.std[2], std::sqrt(12500.0), 1e-3);
  auto x = a;
  normalize_features(x, s);
  EXPECT_NEAR(x[0], (1 - 2.5) / std::sqrt(1.25), 1e-6);
  EXPECT_NEAR(x[1], 0.0, 1e-6);
  denormalize_features(x, s);
  for (size_t i = 0; i < x.size(); ++i) EXPECT_NEAR(x[i], a[i], 1e-4);
}

TEST(FeaturesNorm, NormalisedTrainFeaturesHaveZeroMeanUnitStd) {
  auto f1 = motion_to_features(t2m::testing::synthetic_walk(150));
  auto f2 = motion_to_features(t2m::testing::synthetic_walk(90, 0.3, 1, 1, -0.4, 0.8));
  auto s = compute_feature_stats({&f1, &f2}, kFeatureDim);
  std::vector<double> sum(kFeatureDim, 0), sq(kFeatureDim, 0);
  for (auto* f : {&f1, &f2}) {
    auto x = *f;
    normalize_features(x, s);
    for (size_t i = 0; i < x.size(); ++i) { sum[i % kFeatureDim] += x[i]; sq[i % kFeatureDim] += x[i] * x[i]; }
  }
  const double n = 240;
  for (int d = 0; d < kFeatureDim; ++d) {
    EXPECT_NEAR(sum[d] / n, 0.0, 1e-3) << d;
    if (s.std[d] > (float)kDefaultStdFloor) {
      EXPECT_NEAR(sq[d] / n, 1.0, 1e-3) << d;
    }
  }
}

TEST(FeaturesNorm, SaveLoadIsExact) {
  auto f = motion_to_features(t2m::testing::synthetic_walk(60));
  auto s = compute_feature_stats({&f}, kFeatureDim);
  std::string path = ::testing::TempDir() + "/t2m_feature_stats.json";
  save_feature_stats(s, path);
  auto l = load_feature_stats(path);
  EXPECT_EQ(l.mean, s.mean);
  EXPECT_EQ(l.std, s.std);
  std::remove(path.c_str());
}

TEST(FeaturesNorm, BadInputThrows) {
  std::vector<float> a = {1, 2, 3, 4};
  EXPECT_THROW(compute_feature_stats({&a}, 3), t2m::Error);
  EXPECT_THROW(compute_feature_stats({}, 3), t2m::Error);
  EXPECT_THROW(compute_feature_stats({&a}, 0), t2m::Error);
  EXPECT_THROW(compute_feature_stats({&a}, 2, 0.0), t2m::Error);
  auto s = compute_feature_stats({&a}, 2);
  std::vector<float> odd = {1, 2, 3};
  EXPECT_THROW(normalize_features(odd, s), t2m::Error);
  EXPECT_THROW(denormalize_features(odd, FeatureStats{}), t2m::Error);
  EXPECT_THROW(load_feature_stats("/nonexistent/stats.json"), t2m::Error);
  std::string path = ::testing::TempDir() + "/t2m_feature_stats_bad.json";
  for (const char* text : {"{", "{\"format\": \"t2m-feature-stats-1\", \"dim\": 2, \"mean\": [0, 1], \"std\": [1]}",
                           "{\"format\": \"t2m-feature-stats-1\", \"dim\": 1, \"mean\": [0], \"std\": [0]}",
                           "{\"format\": \"other\", \"dim\": 1, \"mean\": [0], \"std\": [1]}"}) {
    std::ofstream(path) << text;
    EXPECT_THROW(load_feature_stats(path), t2m::Error) << text;
  }
  std::remove(path.c_str());
}
