// test_sim_walk.h — the fixture of the SAMCON tests: our humanoid and the real 60-frame Bandai-Namco walk
// (tests/fixtures/bvh/bandai_walk_60.bvh) retargeted to it, each built once.
#pragma once
#include <memory>
#include <string>

#include "sim/bvh.h"
#include "sim/retarget.h"
#include "sim/skeleton.h"

namespace t2m::sim::test {

inline std::shared_ptr<const Humanoid> humanoid() {
  static auto h = Humanoid::create();
  return h;
}
inline const QposTrajectory& walk() {
  static const QposTrajectory q = retarget(
      *humanoid(), motion_from_bvh(read_bvh(std::string(T2M_SOURCE_DIR) + "/tests/fixtures/bvh/bandai_walk_60.bvh")));
  return q;
}

}  // namespace t2m::sim::test
