// features_norm.cpp — mean/std accumulation in double, in-place (de)normalisation, JSON I/O.
#include "models/data/features_norm.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <unistd.h>

#include "tensor/tensor.h"

namespace t2m::data {

FeatureStats compute_feature_stats(const std::vector<const std::vector<float>*>& clips, int dim, double std_floor) {
  if (dim <= 0) throw Error("compute_feature_stats: dim must be > 0, got " + std::to_string(dim));
  if (!(std_floor > 0)) throw Error("compute_feature_stats: std_floor must be > 0, got " + std::to_string(std_floor));
  std::vector<double> sum(dim, 0.0), sq(dim, 0.0);
  size_t n = 0;
  // Two passes (mean, then centred squares) for accuracy on long data sets.
  for (size_t c = 0; c < clips.size(); ++c) {
    const auto& v = *clips[c];
    if (v.size() % dim != 0)
      throw Error("compute_feature_stats: clip " + std::to_string(c) + " has " + std::to_string(v.size()) +
                  " floats, not a multiple of dim " + std::to_string(dim));
    for (size_t i = 0; i < v.size(); ++i) sum[i % dim] += v[i];
    n += v.size() / dim;
  }
  if (n == 0) throw Error("compute_feature_stats: no frames given");
  FeatureStats s;
  s.mean.resize(dim);
  s.std.resize(dim);
  for (int d = 0; d < dim; ++d) s.mean[d] = (float)(sum[d] / n);
  for (const auto* c : clips)
    for (size_t i = 0; i < c->size(); ++i) {
      double x = (*c)[i] - sum[i % dim] / n;
      sq[i % dim] += x * x;
    }
  for (int d = 0; d < dim; ++d) s.std[d] = (float)std::max(std::sqrt(sq[d] / n), std_floor);
  return s;
}

static void check_rows(const std::vector<float>& rows, const FeatureStats& s, const char* who) {
  if (s.mean.empty() || s.mean.size() != s.std.size())
    throw Error(std::string(who) + ": stats have mean " + std::to_string(s.mean.size()) + " / std " +
                std::to_string(s.std.size()) + " entries");
  if (rows.size() % s.mean.size() != 0)
    throw Error(std::string(who) + ": " + std::to_string(rows.size()) + " floats is not a multiple of dim " +
                std::to_string(s.mean.size()));
}

void normalize_features(std::vector<float>& rows, const FeatureStats& s) {
  check_rows(rows, s, "normalize_features");
  const size_t D = s.mean.size();
  for (size_t i = 0; i < rows.size(); ++i) rows[i] = (rows[i] - s.mean[i % D]) / s.std[i % D];
}

void denormalize_features(std::vector<float>& rows, const FeatureStats& s) {
  check_rows(rows, s, "denormalize_features");
  const size_t D = s.mean.size();
  for (size_t i = 0; i < rows.size(); ++i) rows[i] = rows[i] * s.std[i % D] + s.mean[i % D];
}

void save_feature_stats(const FeatureStats& s, const std::string& path) {
  if (s.mean.size() != s.std.size() || s.mean.empty())
    throw Error("save_feature_stats: mean/std sizes " + std::to_string(s.mean.size()) + "/" +
                std::to_string(s.std.size()));
  std::string tmp = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream f(tmp);
    if (!f) throw Error("save_feature_stats: cannot open '" + tmp + "'");
    auto list = [&](const std::vector<float>& v) {
      std::string out = "[";
      char buf[32];
      for (size_t i = 0; i < v.size(); ++i) {
        std::snprintf(buf, sizeof buf, "%s%.9g", i ? ", " : "", (double)v[i]);
        out += buf;
      }
      return out + "]";
    };
    f << "{\"format\": \"t2m-feature-stats-1\", \"dim\": " << s.mean.size() << ",\n \"mean\": " << list(s.mean)
      << ",\n \"std\": " << list(s.std) << "}\n";
    if (!f) throw Error("save_feature_stats: write failed for '" + tmp + "'");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) throw Error("save_feature_stats: cannot rename to '" + path + "'");
}

FeatureStats load_feature_stats(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw Error("load_feature_stats: cannot open '" + path + "'");
  std::stringstream ss;
  ss << f.rdbuf();
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(ss.str());
  } catch (const std::exception& e) {
    throw Error("load_feature_stats: '" + path + "' is not JSON: " + e.what());
  }
  if (!j.is_object() || j.value("format", "") != "t2m-feature-stats-1" || !j.contains("mean") || !j.contains("std"))
    throw Error("load_feature_stats: '" + path + "' is not a t2m-feature-stats-1 file");
  FeatureStats s;
  try {
    s.mean = j["mean"].get<std::vector<float>>();
    s.std = j["std"].get<std::vector<float>>();
  } catch (const std::exception& e) {
    throw Error("load_feature_stats: '" + path + "': bad mean/std lists: " + e.what());
  }
  if (s.mean.empty() || s.mean.size() != s.std.size() || j.value("dim", -1) != (int)s.mean.size())
    throw Error("load_feature_stats: '" + path + "': dim " + std::to_string(j.value("dim", -1)) + ", mean " +
                std::to_string(s.mean.size()) + ", std " + std::to_string(s.std.size()));
  for (float v : s.std)
    if (!(v > 0)) throw Error("load_feature_stats: '" + path + "': std entries must be > 0");
  return s;
}

}  // namespace t2m::data
