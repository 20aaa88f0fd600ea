// export.h — simulated (or retargeted) humanoid motion -> BVH with the Bandai data's hierarchy, rest pose and
// units (joint_Root + 21 joints, 6 channels each, Zrotation Xrotation Yrotation, centimetres, Y up, the data's
// bone offsets), so that the file re-imports through sim/bvh.h + motion_from_bvh unchanged and opens in Blender.
// How: motion_from_qpos (sim/retarget.h) -> bvh_from_motion (sim/skeleton.h) -> write_bvh (atomic rename).
// Errors: trajectory sizes that do not match the humanoid, unwritable path -> t2m::Error.
#pragma once
#include <string>

#include "sim/bvh.h"
#include "sim/retarget.h"

namespace t2m::sim {

BvhMotion export_bvh(const Humanoid& h, const QposTrajectory& q);
void export_bvh_file(const Humanoid& h, const QposTrajectory& q, const std::string& path);

}  // namespace t2m::sim
