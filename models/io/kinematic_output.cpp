// kinematic_output.cpp — features -> Motion -> humanoid qpos -> BVH / MP4, written through OutputDir.
#include "models/io/kinematic_output.h"

#include <chrono>
#include <cmath>

#include "models/data/features.h"
#include "models/eval/motion_dir.h"
#include "models/io/output_dir.h"
#include "nn/checkpoint.h"
#include "sim/export.h"
#include "sim/position_ik.h"
#include "sim/render.h"
#include "sim/retarget.h"

namespace t2m::io {

namespace {

using json = nlohmann::json;

void check_features(const std::vector<float>& f, const char* who) {
  const size_t D = data::kFeatureDim;
  if (f.empty() || f.size() % D != 0)
    throw Error(std::string(who) + ": features must be [T, " + std::to_string(D) + "] with T >= 1, got " +
                std::to_string(f.size()) + " floats");
  for (size_t i = 0; i < f.size(); ++i)
    if (!std::isfinite(f[i]))
      throw Error(std::string(who) + ": non-finite feature at frame " + std::to_string(i / D) + ", dim " +
                  std::to_string(i % D));
}

}  // namespace

sim::Motion motion_from_features(const std::vector<float>& features) {
  check_features(features, "motion_from_features");
  sim::Motion m;
  m.frames = int(features.size() / data::kFeatureDim);
  m.fps = sim::kCanonicalFps;
  m.pos = data::features_to_positions(features);
  m.offsets = sim::humanoid_offsets();
  std::vector<float> ref(sim::kNumJoints * 4);
  for (int j = 0; j < sim::kNumJoints; ++j)
    for (int k = 0; k < 4; ++k) ref[4 * j + k] = (float)sim::rest_world_rot(j)[k];
  m.rot = sim::rotations_from_positions(m.pos, m.offsets, ref);  // not the generated 6D channels (docs/CASIM.md)
  return m;
}

json write_kinematic_generation(const KinematicOutput& g, std::shared_ptr<const sim::Humanoid> h,
                                const std::string& dir, const KinematicWriteOptions& w) {
  const sim::Motion motion = motion_from_features(g.features);
  OutputDir out(dir, w.overwrite, "generate");

  auto t0 = std::chrono::steady_clock::now();
  auto since = [](std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
  };
  eval::write_npy_features(out.file("features.npy"), g.features, data::kFeatureDim);
  sim::QposTrajectory q = sim::retarget(*h, motion);
  sim::export_bvh_file(*h, q, out.file("motion.bvh"));
  const double export_s = since(t0);
  double render_s = 0;
  if (w.render) {
    t0 = std::chrono::steady_clock::now();
    sim::RenderOptions ro;
    ro.width = w.render_width;
    ro.height = w.render_height;
    sim::render_trajectory(h, q, out.file("render.mp4"), "", ro);
    render_s = since(t0);
  }
  json files = {"features.npy", "motion.bvh"};
  if (w.render) files.push_back("render.mp4");
  files.push_back("metrics.json");
  const json metrics = {
      {"prompt", g.prompt},
      {"model", g.model},
      {"kind", "kinematic (pose features; no physics)"},
      {"frames", motion.frames},
      {"duration_s", double(motion.frames - 1) / motion.fps},
      {"retarget", {{"clamped_hinge_values", q.clamped}, {"floor_shift_m", q.floor_shift}}},
      {"timing_s", {{"generate", g.generate_s}, {"export", export_s}, {"render", render_s}}},
      {"cpu_s", {{"generate", g.generate_cpu_s}}},
      {"info", g.info},
      {"files", files}};
  nn::write_file_atomic(out.file("metrics.json"), metrics.dump(1) + "\n");
  out.commit();
  return metrics;
}

}  // namespace t2m::io
