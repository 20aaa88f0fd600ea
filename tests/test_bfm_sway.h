// test_bfm_sway.h — shared by the BFM tests: the humanoid (built once per test binary) and a standing reference
// whose first six hinges sway slowly (so PD targets and Eq 2 latents change over time).
#pragma once
#include <cmath>
#include <memory>
#include <vector>

#include "sim/humanoid.h"
#include "sim/retarget.h"

namespace t2m::test {

inline std::shared_ptr<const sim::Humanoid> humanoid() {
  static auto h = sim::Humanoid::create();
  return h;
}

// `frames` frames of the standing pose with hinge k (k < 6) at amp * sin(0.2 t + k) off qpos0, velocities from
// finite differences.
inline sim::QposTrajectory swaying(const sim::Humanoid& h, int frames, double amp) {
  sim::QposTrajectory q;
  q.frames = frames;
  q.nq = h.model()->nq;
  q.nv = h.model()->nv;
  for (int t = 0; t < frames; ++t) {
    std::vector<double> p(h.model()->qpos0, h.model()->qpos0 + q.nq);
    for (int k = 0; k < 6; ++k) p[h.hinge_qpos(k)] += amp * std::sin(0.2 * t + k);
    q.qpos.insert(q.qpos.end(), p.begin(), p.end());
  }
  sim::trajectory_velocities(h, q);
  return q;
}

}  // namespace t2m::test
