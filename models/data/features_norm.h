// features_norm.h — per-dimension mean / std of motion features (train split only), saved as JSON.
//
// mean[d] and std[d] are over every frame of every clip given (use the train clips only; the caller picks them),
// accumulated in double. std[d] = max(sqrt(var[d]), std_floor) so that constant dimensions (e.g. a contact that
// never fires) do not blow up. normalize: (x - mean) / std; denormalize: x * std + mean. Buffers are [T, D] rows.
// Errors: t2m::Error on empty input, rows that are not a multiple of D, dims that do not match, std_floor <= 0,
// or a JSON file that is missing, malformed or has lists of different lengths.
#pragma once
#include <string>
#include <vector>

namespace t2m::data {

struct FeatureStats {
  std::vector<float> mean, std;
  int dim() const { return (int)mean.size(); }
};

// 1e-3: 1 mm, 1 mm per frame (3 cm/s), 1e-3 of a 6D entry. On the Bandai train split only 4 dims fall below it
// (6D entries of the knees, which are hinge-like); velocities per frame have std ~5e-3, so 1e-2 would be too high.
inline constexpr double kDefaultStdFloor = 1e-3;

FeatureStats compute_feature_stats(const std::vector<const std::vector<float>*>& clips, int dim,
                                   double std_floor = kDefaultStdFloor);
void normalize_features(std::vector<float>& rows, const FeatureStats& s);    // in place
void denormalize_features(std::vector<float>& rows, const FeatureStats& s);  // in place

// {"format": "t2m-feature-stats-1", "dim": D, "mean": [...], "std": [...]} (floats as %.9g: exact float32).
void save_feature_stats(const FeatureStats& s, const std::string& path);
FeatureStats load_feature_stats(const std::string& path);

}  // namespace t2m::data
