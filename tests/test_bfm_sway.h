// test_bfm_sway.h — shared by the BFM tests: the humanoid (built once per test binary), a standing reference
// whose first six hinges sway slowly (so PD targets and Eq 2 latents change over time), references made of such
// sways, and a tiny FB config.
#pragma once
#include <cmath>
#include <memory>
#include <vector>

#include <string>
#include <utility>

#include "models/bfm/fb_agent.h"
#include "models/bfm/ref_motions.h"
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

// References "clip0", "clip1", ...: one sway per (frames, amplitude).
inline bfm::RefMotions sway_refs(const std::vector<std::pair<int, double>>& clips) {
  bfm::RefMotions r;
  for (size_t i = 0; i < clips.size(); ++i)
    r.add(*humanoid(), "clip" + std::to_string(i), swaying(*humanoid(), clips[i].first, clips[i].second));
  return r;
}

// An FB agent config small enough for unit tests (width 16, d = 6, Eq 2 window 3).
inline bfm::FbConfig tiny_fb_config() {
  bfm::FbConfig c;
  c.hidden = 16;
  c.b_hidden = 16;
  c.z_dim = 6;
  c.track_window = 3;
  return c;
}

}  // namespace t2m::test
