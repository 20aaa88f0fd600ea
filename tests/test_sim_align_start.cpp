// test_sim_align_start.cpp — sim/align_start.h: a trajectory moved rigidly on the floor starts at the given root
// position and heading, keeps its shape (joint positions relative to the root, heights, hinges), its velocities are
// those of the moved positions, and wrong sizes are refused.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "sim/align_start.h"
#include "sim/humanoid.h"
#include "sim/retarget.h"
#include "tensor/tensor.h"

using namespace t2m;
using namespace t2m::sim;

namespace {

std::shared_ptr<const Humanoid> hum() {
  static auto h = Humanoid::create();
  return h;
}

// Root walking along a turning arc (yaw 0.7 + 0.02 t) with six hinges swaying: a trajectory far from the origin.
QposTrajectory turning_walk(const Humanoid& h, int frames) {
  QposTrajectory q;
  q.frames = frames, q.nq = h.model()->nq, q.nv = h.model()->nv;
  for (int t = 0; t < frames; ++t) {
    std::vector<double> p(h.model()->qpos0, h.model()->qpos0 + q.nq);
    const double yaw = 0.7 + 0.02 * t;
    p[0] = 1.5 + 0.03 * t * std::cos(yaw), p[1] = -2.0 + 0.03 * t * std::sin(yaw), p[2] += 0.01 * std::sin(0.3 * t);
    p[3] = std::cos(yaw / 2), p[4] = 0, p[5] = 0.05 * std::sin(0.1 * t), p[6] = std::sin(yaw / 2);
    const double n = std::sqrt(p[3] * p[3] + p[5] * p[5] + p[6] * p[6]);
    p[3] /= n, p[5] /= n, p[6] /= n;
    for (int k = 0; k < 6; ++k) p[h.hinge_qpos(k)] += 0.3 * std::sin(0.2 * t + k);
    q.qpos.insert(q.qpos.end(), p.begin(), p.end());
  }
  trajectory_velocities(h, q);
  return q;
}

}  // namespace

TEST(SimAlignStart, RootYawIsTheAngleOfARotationAboutZ) {
  for (double a : {-2.5, -0.3, 0.0, 1.0, 3.0}) {
    const double q[4] = {std::cos(a / 2), 0, 0, std::sin(a / 2)};
    EXPECT_NEAR(root_yaw(q), a, 1e-12) << a;
  }
}

TEST(SimAlignStart, StartsWhereTheBodyStandsAndKeepsTheMotionsShape) {
  const Humanoid& h = *hum();
  const int nq = h.model()->nq;
  const QposTrajectory q = turning_walk(h, 40);
  std::vector<double> start(h.model()->qpos0, h.model()->qpos0 + nq);
  start[0] = 0.3, start[1] = 0.2, start[3] = std::cos(0.6), start[6] = std::sin(0.6);  // yaw 1.2 at (0.3, 0.2)
  const QposTrajectory m = align_start(h, q, start.data());
  ASSERT_EQ(m.frames, q.frames);
  EXPECT_NEAR(m.qpos[0], 0.3, 1e-12);
  EXPECT_NEAR(m.qpos[1], 0.2, 1e-12);
  EXPECT_NEAR(root_yaw(m.qpos.data() + 3), 1.2, 1e-12);
  for (int t = 0; t < q.frames; ++t) {
    const double* a = q.qpos.data() + (size_t)t * nq;
    const double* b = m.qpos.data() + (size_t)t * nq;
    EXPECT_EQ(b[2], a[2]) << t;                                                     // height unchanged
    for (int k = 7; k < nq; ++k) ASSERT_EQ(b[k], a[k]) << t << " " << k;           // hinges unchanged
    EXPECT_NEAR(root_yaw(b + 3) - root_yaw(a + 3), 1.2 - root_yaw(q.qpos.data() + 3), 1e-9) << t;
  }
  // Every joint keeps its height and its floor distance to the frame-0 root (a rigid move about it).
  const std::vector<float> pa = replay_joint_positions(h, q), pb = replay_joint_positions(h, m);
  ASSERT_EQ(pa.size(), pb.size());
  for (size_t i = 0; i < pa.size() / 3; ++i) {
    EXPECT_NEAR(pb[3 * i + 2], pa[3 * i + 2], 1e-5) << i;
    const double da = std::hypot(pa[3 * i] - q.qpos[0], pa[3 * i + 1] - q.qpos[1]);
    const double db = std::hypot(pb[3 * i] - 0.3, pb[3 * i + 1] - 0.2);
    EXPECT_NEAR(db, da, 2e-5) << i;
  }
  EXPECT_GT(std::hypot(pb[0] - pa[0], pb[1] - pa[1]), 1.0);  // it did move
  // The velocities are those of the moved positions: root linear velocity turned, local angular velocity kept.
  QposTrajectory again = m;
  trajectory_velocities(h, again);
  for (size_t i = 0; i < m.qvel.size(); ++i) ASSERT_NEAR(m.qvel[i], again.qvel[i], 1e-9) << i;
  EXPECT_GT(std::abs(m.qvel[0] - q.qvel[0]), 1e-3);  // and they did turn
}

TEST(SimAlignStart, RefusesWrongSizes) {
  const Humanoid& h = *hum();
  QposTrajectory q = turning_walk(h, 5);
  const double* start = h.model()->qpos0;
  QposTrajectory none = q;
  none.frames = 0, none.qpos.clear(), none.qvel.clear();
  EXPECT_THROW(align_start(h, none, start), Error);
  QposTrajectory short_qvel = q;
  short_qvel.qvel.pop_back();
  EXPECT_THROW(align_start(h, short_qvel, start), Error);
  QposTrajectory other = q;
  other.nq += 1;
  EXPECT_THROW(align_start(h, other, start), Error);
}
