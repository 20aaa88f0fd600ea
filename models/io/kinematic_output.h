// kinematic_output.h — the output directory of a kinematic text-to-motion model (`t2m generate --model NAME`: the
// CASIM and PRO-Motion baselines, which generate pose features directly instead of driving the simulator).
//
//   DIR/features.npy   the generated raw features [T, 257] (models/data/features.h), float32 .npy: what
//                      `t2m eval motions` scores (exactly, no simulation or retargeting in between)
//   DIR/motion.bvh     the motion (rotations solved from the generated positions) retargeted onto our humanoid (sim/retarget.h: joint limits clamp, feet put on the
//                      floor) and exported with the Bandai hierarchy (sim/export.h), Blender-ready
//   DIR/render.mp4     kinematic replay of that retargeted motion (no physics), unless render = false
//   DIR/metrics.json   prompt, model, frames, duration, clamped hinge values, timing, the model's `info`
// Written atomically (models/io/output_dir.h): all files or none.
// Errors (t2m::Error): features not a whole number of non-empty frames or non-finite, plus OutputDir's.
#pragma once
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "sim/humanoid.h"
#include "sim/skeleton.h"

namespace t2m::io {

struct KinematicOutput {
  std::string prompt, model;
  std::vector<float> features;  // [T, 257] raw
  nlohmann::json info = nlohmann::json::object();  // model-specific (checkpoints, steps, guidance, ...)
  double generate_s = 0, generate_cpu_s = 0;        // wall / process CPU seconds of the model
};

// Canonical Motion of raw features: positions from the exact inverse of features.h, the humanoid's rest offsets
// (sim::humanoid_offsets), and local rotations solved from the positions (sim/position_ik.h), NOT the features' 6D
// rotation channels: models trained with mirror augmentation generate a blend of two rotation conventions there
// (docs/CASIM.md "Known defect"), while their positions are consistent. fps 30.
sim::Motion motion_from_features(const std::vector<float>& features);

struct KinematicWriteOptions {
  bool render = true, overwrite = false;
  int render_width = 640, render_height = 480;
};
// Writes DIR (see above); returns metrics.json's content.
nlohmann::json write_kinematic_generation(const KinematicOutput& g, std::shared_ptr<const sim::Humanoid> h,
                                          const std::string& dir, const KinematicWriteOptions& w);

}  // namespace t2m::io
