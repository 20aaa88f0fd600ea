// test_sim_position_ik.cpp — sim/position_ik.h: rotations from positions reproduce the bone directions through FK,
// keep a known pose's rotations where they are observable, give an upright retargeted root, and refuse bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "sim/humanoid.h"
#include "sim/position_ik.h"
#include "sim/retarget.h"
#include "sim/skeleton.h"
#include "tensor/tensor.h"
#include "test_features_synthetic.h"

namespace {

using t2m::Error;
namespace sim = t2m::sim;

// FK of (rot, offsets) from the given root positions: [T, 21, 3].
std::vector<float> fk(const std::vector<float>& rot, const std::vector<float>& offsets, const std::vector<float>& pos) {
  const int T = int(pos.size() / 63);
  std::vector<float> out(pos.size());
  for (int t = 0; t < T; ++t)
    sim::forward_kinematics(rot.data() + t * 84, offsets.data(), sim::kJointParents.data(), sim::kNumJoints,
                            pos.data() + t * 63, out.data() + t * 63);
  return out;
}

double max_bone_direction_error(const std::vector<float>& a, const std::vector<float>& b) {
  double worst = 0;
  for (size_t t = 0; t < a.size() / 63; ++t)
    for (int j = 1; j < sim::kNumJoints; ++j) {
      const int p = sim::kJointParents[j];
      double da[3], db[3], na = 0, nb = 0, dot = 0;
      for (int k = 0; k < 3; ++k) {
        da[k] = a[t * 63 + 3 * j + k] - a[t * 63 + 3 * p + k];
        db[k] = b[t * 63 + 3 * j + k] - b[t * 63 + 3 * p + k];
        na += da[k] * da[k], nb += db[k] * db[k], dot += da[k] * db[k];
      }
      worst = std::max(worst, std::acos(std::clamp(dot / std::sqrt(na * nb), -1.0, 1.0)));
    }
  return worst;  // radians
}

TEST(PositionIk, FkOfTheSolutionReproducesEveryBoneDirection) {
  const sim::Motion m = t2m::testing::synthetic_walk(30);
  const auto rot = sim::rotations_from_positions(m.pos, m.offsets);
  ASSERT_EQ(rot.size(), m.rot.size());
  const auto pos = fk(rot, m.offsets, m.pos);
  EXPECT_LT(max_bone_direction_error(pos, m.pos), 1e-3);
  // Exact FK positions and the same offsets: joint positions themselves are reproduced.
  double err = 0;
  for (size_t i = 0; i < pos.size(); ++i) err = std::max(err, (double)std::fabs(pos[i] - m.pos[i]));
  EXPECT_LT(err, 1e-4);
}

TEST(PositionIk, DifferentBoneLengthsStillGiveTheDirections) {
  // The humanoid's offsets (other bone lengths than the synthetic skeleton): directions are matched.
  const sim::Motion m = t2m::testing::synthetic_walk(20);
  const auto offs = sim::humanoid_offsets();
  const auto rot = sim::rotations_from_positions(m.pos, offs);
  const auto pos = fk(rot, offs, m.pos);
  // Single-child bones exactly; branching joints in the least-squares sense (small residual).
  EXPECT_LT(max_bone_direction_error(pos, m.pos), 0.35);
}

TEST(PositionIk, RetargetedRootStaysUpright) {
  // A standing pose solved from positions retargets with the root's up axis near world up.
  const sim::Motion m = t2m::testing::synthetic_stand(5);
  sim::Motion ik = m;
  ik.offsets = sim::humanoid_offsets();
  ik.rot = sim::rotations_from_positions(m.pos, ik.offsets);
  auto h = sim::Humanoid::create();
  const auto q = sim::retarget(*h, ik);
  const double* r = q.qpos.data() + 3;  // free-joint quaternion (w, x, y, z)
  const double up_z = 1 - 2 * (r[1] * r[1] + r[2] * r[2]);  // z component of the body's z axis
  EXPECT_GT(up_z, 0.9);
}

TEST(PositionIk, HumanoidPosesRoundTripWithTheReferenceTwist) {
  // Humanoid poses (hinges at 40% of a random point of their range, root turned and lifted) -> Motion -> positions
  // -> IK with the humanoid's reference rotations -> retarget: the same joint positions, nothing clamped.
  auto h = sim::Humanoid::create();
  const mjModel* mm = h->model();
  sim::QposTrajectory q;
  q.frames = 6, q.nq = mm->nq, q.nv = mm->nv;
  q.qpos.assign((size_t)q.frames * q.nq, 0.0);
  uint32_t state = 12345;
  auto uniform = [&] { state = state * 1664525u + 1013904223u; return (state >> 8) / double(1 << 24); };
  for (int t = 0; t < q.frames; ++t) {
    double* qp = q.qpos.data() + (size_t)t * q.nq;
    const int r = h->root_qpos();
    qp[r + 2] = 1.0;
    const double yaw = 0.3 * t;
    qp[r + 3] = std::cos(yaw / 2), qp[r + 6] = std::sin(yaw / 2);
    for (int k = 0; k < sim::kHumanoidHinges; ++k) {
      const int jnt = mm->dof_jntid[h->hinge_dof(k)];
      const double lo = mm->jnt_range[2 * jnt], hi = mm->jnt_range[2 * jnt + 1];
      qp[h->hinge_qpos(k)] = 0.4 * (lo + (hi - lo) * uniform());
    }
  }
  sim::trajectory_velocities(*h, q);
  const sim::Motion m = sim::motion_from_qpos(*h, q);
  std::vector<float> ref(sim::kNumJoints * 4);
  for (int j = 0; j < sim::kNumJoints; ++j)
    for (int k = 0; k < 4; ++k) ref[4 * j + k] = (float)sim::rest_world_rot(j)[k];
  sim::Motion ik = m;
  ik.rot = sim::rotations_from_positions(m.pos, m.offsets, ref);
  const auto back = sim::retarget(*h, ik);
  EXPECT_EQ(back.clamped, 0);
  EXPECT_LT(sim::replay_error(*h, back, m).max_m, 2e-3);
  // Without the reference twist the single-child joints get implausible twists that the joint limits clamp.
  sim::Motion plain = m;
  plain.rot = sim::rotations_from_positions(m.pos, m.offsets);
  EXPECT_GT(sim::retarget(*h, plain).clamped, 0);
  EXPECT_THROW(sim::rotations_from_positions(m.pos, m.offsets, std::vector<float>(10, 0.f)), Error);
}

TEST(PositionIk, BadInput) {
  const auto offs = sim::humanoid_offsets();
  EXPECT_THROW(sim::rotations_from_positions({}, offs), Error);
  EXPECT_THROW(sim::rotations_from_positions(std::vector<float>(62, 0.f), offs), Error);
  EXPECT_THROW(sim::rotations_from_positions(std::vector<float>(63, 0.f), std::vector<float>(60, 0.f)), Error);
  std::vector<float> p(63, 0.f);
  p[7] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(sim::rotations_from_positions(p, offs), Error);
}

}  // namespace
