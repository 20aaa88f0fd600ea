// export.cpp — qpos trajectory -> canonical Motion -> BVH file (see export.h).
#include "sim/export.h"

namespace t2m::sim {

BvhMotion export_bvh(const Humanoid& h, const QposTrajectory& q) { return bvh_from_motion(motion_from_qpos(h, q)); }

void export_bvh_file(const Humanoid& h, const QposTrajectory& q, const std::string& path) {
  write_bvh(export_bvh(h, q), path);
}

}  // namespace t2m::sim
