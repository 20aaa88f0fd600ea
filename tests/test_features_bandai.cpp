// test_features_bandai.cpp — features on real motion capture: the committed 60-frame fixture, and whole clips
// extracted from /work/shared/data/bandai (or $T2M_DATA) when the archives are present (skipped otherwise).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "models/data/features.h"
#include "models/data/features_mirror.h"
#include "sim/bvh.h"
#include "sim/skeleton.h"
#include "tensor/tensor.h"
#include "test_scratch_dir.h"

using namespace t2m::data;
namespace sim = t2m::sim;
namespace fs = std::filesystem;

namespace {

double max_joint_err(const std::vector<float>& a, const std::vector<float>& b) {
  double m = 0;
  for (size_t i = 0; i + 2 < a.size(); i += 3) {
    double dx = a[i] - b[i], dy = a[i + 1] - b[i + 1], dz = a[i + 2] - b[i + 2];
    m = std::max(m, std::sqrt(dx * dx + dy * dy + dz * dz));
  }
  return m;
}

std::string data_dir() {
  if (const char* e = std::getenv("T2M_DATA")) return e;
  for (std::string d : {std::string(T2M_SOURCE_DIR) + "/../shared/data/bandai", std::string("/work/shared/data/bandai")})
    if (fs::exists(d + "/dataset-1.tar.zst")) return d;
  return "";
}

// Extracts one member of dataset-N.tar.zst into a temp dir (zstd | tar of a single member); "" when impossible.
std::string extract_clip(int dataset, const std::string& name) {
  std::string dir = data_dir();
  if (dir.empty()) return "";
  const std::string out = (t2m::test::scratch_root() / "bandai").string();
  fs::create_directories(out);
  std::string member = "Bandai-Namco-Research-Motiondataset-" + std::to_string(dataset) + "/data/" + name + ".bvh";
  std::string path = out + "/" + member;
  if (fs::exists(path)) return path;
  std::string cmd = "zstd -dc '" + dir + "/dataset-" + std::to_string(dataset) + ".tar.zst' 2>/dev/null | tar -x -C '" +
                    out + "' '" + member + "' 2>/dev/null";
  if (std::system(cmd.c_str()) != 0 || !fs::exists(path)) return "";
  return path;
}

void check_round_trip(const sim::Motion& m, const std::string& what) {
  auto f = motion_to_features(m);
  auto canon = canonicalize_motion(m);
  double err = max_joint_err(features_to_positions(f), canon.pos);
  std::printf("%s: %d frames, round-trip max joint error %.4f mm\n", what.c_str(), m.frames, err * 1000);
  EXPECT_LT(err, 1e-3) << what << ": round trip " << err * 1000 << " mm";
  // Mirror: twice = identity, feature-space mirror = recomputed features.
  auto mf = mirror_features(f);
  EXPECT_EQ(mirror_features(mf), f) << what;
  auto mr = motion_to_features(mirror_motion(m));
  double merr = 0;
  for (size_t i = 0; i < mr.size(); ++i) merr = std::max(merr, (double)std::fabs(mr[i] - mf[i]));
  EXPECT_LT(merr, 1e-4) << what;
}

}  // namespace

TEST(FeaturesBandai, FixtureWalkRoundTripAndHeading) {
  auto m = sim::motion_from_bvh(sim::read_bvh(std::string(T2M_SOURCE_DIR) + "/tests/fixtures/bvh/bandai_walk_60.bvh"));
  ASSERT_EQ(m.frames, 60);
  check_round_trip(m, "fixture");
  // The Bandai performers walk forward: in the heading frame the root moves along +x, little sideways.
  auto f = motion_to_features(m);
  double fwd = 0, side = 0;
  for (int t = 1; t < m.frames; ++t) {
    fwd += f[t * kFeatureDim + kFeatRootVel];
    side += std::fabs(f[t * kFeatureDim + kFeatRootVel + 1]);
  }
  EXPECT_GT(fwd / (m.frames - 1) * m.fps, 0.3) << "mean forward speed m/s";
  EXPECT_LT(side, 0.5 * fwd);
  // Hips height in a plausible range (metres, Z up).
  EXPECT_GT(f[kFeatRootHeight], 0.7);
  EXPECT_LT(f[kFeatRootHeight], 1.2);
}

TEST(FeaturesBandai, WholeClipsRoundTripUnderOneMillimetre) {
  struct Clip { int dataset; const char* name; };
  int done = 0;
  for (Clip c : {Clip{1, "dataset-1_walk_normal_001"}, Clip{1, "dataset-1_dance-short_normal_001"},
                 Clip{2, "dataset-2_walk-turn-left_exhausted_001"}}) {
    std::string path = extract_clip(c.dataset, c.name);
    if (path.empty()) continue;
    auto m = sim::motion_from_bvh(sim::read_bvh(path));
    check_round_trip(m, c.name);
    // Contacts on a walk: each foot is in contact for a sizeable part of the clip but not always.
    if (std::string(c.name).find("walk_normal") != std::string::npos) {
      auto f = motion_to_features(m);
      double left = 0;
      for (int t = 0; t < m.frames; ++t) left += f[t * kFeatureDim + kFeatContact];
      EXPECT_GT(left / m.frames, 0.15);
      EXPECT_LT(left / m.frames, 0.9);
    }
    ++done;
  }
  if (done == 0) GTEST_SKIP() << "Bandai archives not found (set T2M_DATA)";
}
