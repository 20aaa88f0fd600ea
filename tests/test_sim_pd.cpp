// test_sim_pd.cpp — PD tracking baseline metrics and BVH export of simulated motion.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/export.h"
#include "sim/pd_tracker.h"
#include "tensor/tensor.h"

using namespace t2m::sim;

namespace {
std::shared_ptr<const Humanoid> humanoid() {
  static auto h = Humanoid::create();
  return h;
}
// The reference pose held still for `frames` frames (qpos0 = standing on the soles).
QposTrajectory standing(const Humanoid& h, int frames) {
  QposTrajectory q;
  q.frames = frames;
  q.nq = h.model()->nq;
  for (int t = 0; t < frames; ++t) q.qpos.insert(q.qpos.end(), h.model()->qpos0, h.model()->qpos0 + q.nq);
  trajectory_velocities(h, q);
  return q;
}
}  // namespace

TEST(SimPd, TracksStandingForHalfASecond) {
  Env env(humanoid());
  const QposTrajectory ref = standing(*humanoid(), 15);
  const PdResult r = track_pd(env, ref);
  EXPECT_TRUE(r.success);
  EXPECT_FALSE(r.fell);
  EXPECT_EQ(r.frames_ok, 15);
  EXPECT_LT(r.mpjpe_m, 0.05);
  EXPECT_LT(r.root_drift_m, 0.15);  // pure PD starts to tip over (no balance), but slowly
  EXPECT_EQ(r.assist_force, 0.0);
  EXPECT_EQ(r.simulated.frames, 15);
  // Frame 0 of the simulation is the reference start state.
  for (int i = 0; i < ref.nq; ++i) EXPECT_EQ(r.simulated.qpos[i], ref.qpos[i]);
}

TEST(SimPd, TeleportingReferenceFailsAtTheJump) {
  // The reference root jumps 1 m sideways at frame 8: the body cannot follow, so tracking fails there.
  Env env(humanoid());
  QposTrajectory ref = standing(*humanoid(), 12);
  for (int t = 8; t < 12; ++t) ref.qpos[(size_t)t * ref.nq + 1] += 1.0;
  trajectory_velocities(*humanoid(), ref);
  const PdResult r = track_pd(env, ref);
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.frames_ok, 8);
  EXPECT_GT(r.max_error_m, 0.5);
  EXPECT_GT(r.root_drift_m, 0.5);
}

TEST(SimPd, BadReferenceThrows) {
  Env env(humanoid());
  QposTrajectory ref = standing(*humanoid(), 3);
  ref.qvel.pop_back();
  EXPECT_THROW(track_pd(env, ref), t2m::Error);
  ref = standing(*humanoid(), 3);
  ref.qpos[7] = NAN;
  EXPECT_THROW(track_pd(env, ref), t2m::Error);  // Env::reset rejects non-finite qpos
}

TEST(SimExport, BvhReimportsUnchanged) {
  const auto& h = *humanoid();
  Env env(humanoid());
  // A short simulated motion: PD tracking of a reference whose knees and elbows bend.
  QposTrajectory ref = standing(h, 6);
  const mjModel* m = h.model();
  for (int t = 0; t < 6; ++t) {
    ref.qpos[(size_t)t * ref.nq + mj_name2id(m, mjOBJ_JOINT, "LowerLeg_L_y") + 6] += 0.05 * t;
    ref.qpos[(size_t)t * ref.nq + mj_name2id(m, mjOBJ_JOINT, "LowerArm_R_y") + 6] += 0.1 * t;
  }
  trajectory_velocities(h, ref);
  const QposTrajectory sim = track_pd(env, ref).simulated;
  const BvhMotion bvh = export_bvh(h, sim);
  // The data's layout: joint_Root + 21 joints, 6 channels each, Zrotation Xrotation Yrotation, cm offsets.
  ASSERT_EQ(bvh.joints.size(), 22u);
  EXPECT_EQ(bvh.joints[0].name, "joint_Root");
  EXPECT_EQ(bvh.joints[14].name, "UpperLeg_L");
  EXPECT_NEAR(bvh.joints[15].offset[0], 39.0811, 1e-3);  // LowerLeg_L bone, cm along local x
  EXPECT_EQ(bvh.joints[3].channels[3], Channel::Zrotation);
  EXPECT_NEAR(bvh.frame_time, 1.0 / 30, 1e-6);
  // Re-import through the text form and retarget: the same qpos and joint positions.
  const Motion back = motion_from_bvh(parse_bvh(bvh_to_string(bvh), "export"));
  const QposTrajectory q2 = retarget(h, back);
  const std::vector<float> p1 = replay_joint_positions(h, sim), p2 = replay_joint_positions(h, q2);
  double worst = 0;
  for (size_t i = 0; i < p1.size(); ++i) {
    const double shift = (i % 3 == 2) ? q2.floor_shift : 0.0;
    worst = std::max(worst, std::abs(p1[i] - (p2[i] - shift)));
  }
  EXPECT_LT(worst, 2e-4);  // 6 significant digits in the file
  EXPECT_THROW(export_bvh_file(h, sim, "/nonexistent-dir/x.bvh"), t2m::Error);
}
