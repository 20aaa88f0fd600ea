// test_sim_retarget.cpp — retargeting (Motion <-> qpos), kinematic replay and the Euler helpers.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>

#include "sim/bvh.h"
#include "sim/env.h"
#include "sim/retarget.h"
#include "sim/skeleton.h"
#include "tensor/tensor.h"

using namespace t2m::sim;

namespace {
// Two frames (0 and 57) of Bandai-Namco-Research-Motiondataset-2, dataset-2_walk_normal_001 (CC BY-NC 4.0).
const char* kWalkBvh = R"(
HIERARCHY
ROOT joint_Root
{
 OFFSET 0.0 0.0 0.0
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 JOINT Hips
 {
 OFFSET -0.726466 93.3139 -2.00062
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 JOINT Spine
 {
 OFFSET 15.7357 0.0 0.0
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 JOINT Chest
 {
 OFFSET 8.98455 -0.406207 0.0
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 JOINT Neck
 {
 OFFSET 16.3773 0.0 0.0
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 JOINT Head
 {
 OFFSET 6.45672 0.0 0.0
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 End Site
 {
 OFFSET 0.0 0.0 0.0
 }
 }
 }
 JOINT Shoulder_L
 {
 OFFSET 12.9942 -0.242716 4.98039
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 JOINT UpperArm_L
 {
 OFFSET 5.34809 0.0 0.0
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 JOINT LowerArm_L
 {
 OFFSET 24.3286 1.87007e-05 0.0
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 JOINT Hand_L
 {
 OFFSET 22.2916 0.0 0.0
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 End Site
 {
 OFFSET 0.0 0.0 0.0
 }
 }
 }
 }
 }
 JOINT Shoulder_R
 {
 OFFSET 12.9945 -0.242716 -4.98039
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 JOINT UpperArm_R
 {
 OFFSET -5.34813 0.0 0.0
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 JOINT LowerArm_R
 {
 OFFSET -24.3289 0.000322201 0.0
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 JOINT Hand_R
 {
 OFFSET -22.2915 -0.000108084 0.0
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 End Site
 {
 OFFSET 0.0 0.0 0.0
 }
 }
 }
 }
 }
 }
 }
 JOINT UpperLeg_L
 {
 OFFSET -2.19248 -6.46944 0.0
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 JOINT LowerLeg_L
 {
 OFFSET 39.0811 0.0 -1.23785e-05
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 JOINT Foot_L
 {
 OFFSET 40.9854 0.0 -1.26872e-05
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 JOINT Toes_L
 {
 OFFSET 11.7543 0.0 0.0
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 End Site
 {
 OFFSET 0.0 0.0 0.0
 }
 }
 }
 }
 }
 JOINT UpperLeg_R
 {
 OFFSET -2.19251 6.46944 0.0
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 JOINT LowerLeg_R
 {
 OFFSET -39.0811 -0.00228153 -0.0401928
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 JOINT Foot_R
 {
 OFFSET -40.9854 0.0 0.0
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 JOINT Toes_R
 {
 OFFSET -11.7543 0.0 0.0
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 End Site
 {
 OFFSET 0.0 0.0 0.0
 }
 }
 }
 }
 }
 }
}
MOTION
Frames: 2
Frame Time: 0.0333333
0.000000 0.000000 0.000000 0.000000 0.000000 -0.000000 1.120560 93.148800 -543.347000 90.282500 -6.483260 0.618737 15.735700 0.000005 -0.000001 105.318000 85.346400 -105.641000 8.984550 -0.406207 -0.000000 1.218880 2.476110 -0.671080 16.377300 -0.000001 -0.000001 2.255770 -0.429030 2.266540 6.456720 -0.000001 -0.000000 5.965060 -0.152509 -3.816700 12.994200 -0.242716 4.980390 -89.513100 -1.272140 -69.054800 5.348090 -0.000007 -0.000001 -71.405500 32.537100 -7.412790 24.328600 0.000019 0.000005 3.832450 7.294490 -27.815800 22.291600 -0.000001 0.000005 5.231630 5.552240 -8.811860 12.994500 -0.242716 -4.980390 87.718800 7.463880 -72.951300 -5.348130 -0.000001 -0.000004 -60.024900 40.699000 -13.447000 -24.328900 0.000322 -0.000009 2.665840 5.038340 -27.941100 -22.291500 -0.000108 -0.000004 6.796670 5.491830 -6.207710 -2.192480 -6.469440 -0.000000 179.195000 -4.500530 -11.083100 39.081100 -0.000007 -0.000012 -0.019856 0.072431 15.329500 40.985400 -0.000006 -0.000013 1.316590 -1.077510 -55.331600 11.754300 -0.000000 0.000003 -0.002265 -0.031995 -17.877800 -2.192510 6.469440 -0.000001 179.320000 13.285000 179.746000 -39.081100 -0.002282 -0.040193 -0.002563 0.023255 14.222600 -40.985400 0.000008 0.000006 3.614720 -3.191240 -63.125500 -11.754300 -0.000006 -0.000006 -0.010249 -0.105490 -20.871400
0.000000 0.000000 0.000000 0.000000 0.000000 -0.000000 6.002390 92.090600 -405.421000 89.467500 -3.992550 4.104080 15.735700 0.000005 -0.000001 86.496400 84.408800 -86.287900 8.984550 -0.406207 -0.000000 3.396860 -0.690514 0.436979 16.377300 -0.000001 -0.000001 0.737034 -1.439700 1.835250 6.456720 -0.000001 -0.000000 2.546380 0.513562 -3.615450 12.994200 -0.242716 4.980390 -89.518400 -1.393630 -70.934800 5.348090 -0.000007 -0.000001 -69.198500 32.843300 -13.621000 24.328600 0.000019 0.000005 3.771450 7.337000 -27.304100 22.291600 -0.000001 0.000005 8.224790 5.499010 -6.493580 12.994500 -0.242716 -4.980390 88.053900 5.851910 -71.568900 -5.348130 -0.000001 -0.000004 -70.026900 28.263200 -2.783610 -24.328900 0.000322 -0.000009 3.368150 12.335600 -15.406500 -22.291500 -0.000108 -0.000004 8.224580 5.362990 -1.770690 -2.192480 -6.469440 -0.000000 179.197000 -8.291380 -2.247010 39.081100 -0.000007 -0.000012 -0.080952 0.193713 22.680000 40.985400 -0.000006 -0.000013 3.531040 2.023850 -66.957000 11.754300 -0.000000 0.000003 -0.002183 -0.030995 -17.837100 -2.192510 6.469440 -0.000001 176.991000 10.764500 160.711000 -39.081100 -0.002282 -0.040193 0.087381 -0.050203 59.187700 -40.985400 0.000008 0.000006 2.492500 -4.791900 -51.360300 -11.754300 -0.000006 -0.000006 -0.015626 -0.141723 -22.356400
)";

std::shared_ptr<const Humanoid> humanoid() {
  static auto h = Humanoid::create();
  return h;
}

// A random hinge configuration inside 60% of every range, random root pose.
QposTrajectory random_trajectory(const Humanoid& h, int frames, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  const mjModel* m = h.model();
  QposTrajectory q;
  q.frames = frames;
  q.nq = m->nq;
  q.nv = m->nv;
  q.qpos.assign((size_t)frames * m->nq, 0);
  for (int t = 0; t < frames; ++t) {
    double* qp = q.qpos.data() + (size_t)t * m->nq;
    qp[0] = u(rng), qp[1] = u(rng), qp[2] = 1.0 + 0.1 * u(rng);
    double n = 0;
    for (int k = 3; k < 7; ++k) {
      qp[k] = u(rng);
      n += qp[k] * qp[k];
    }
    for (int k = 3; k < 7; ++k) qp[k] /= std::sqrt(n);
    for (int k = 0; k < kHumanoidHinges; ++k) {
      const int jid = m->actuator_trnid[2 * k];
      const double lo = m->jnt_range[2 * jid], hi = m->jnt_range[2 * jid + 1];
      qp[h.hinge_qpos(k)] = 0.5 * (lo + hi) + 0.3 * (hi - lo) * u(rng);
    }
  }
  trajectory_velocities(h, q);
  return q;
}
}  // namespace

TEST(SimRetarget, EulerRoundTripAllOrders) {
  const int orders[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.4, 1.4);
  for (auto& o : orders)
    for (int trial = 0; trial < 50; ++trial) {
      const double e[3] = {2 * u(rng), u(rng), 2 * u(rng)};
      double R[9], back[3];
      euler_to_matrix(o, e, R);
      matrix_to_euler(o, R, back);
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(back[k], e[k], 1e-9) << o[0] << o[1] << o[2];
    }
  // X then Y by 90 degrees maps z to ... : Rx(90) Ry(90) e_z = Rx(90) e_x = e_x.
  const int xyz[3] = {0, 1, 2};
  const double e[3] = {M_PI / 2, M_PI / 2, 0};
  double R[9];
  euler_to_matrix(xyz, e, R);
  EXPECT_NEAR(R[2], 1.0, 1e-12);  // column z, row x
  const int bad[3] = {0, 0, 1};
  double out[3];
  EXPECT_THROW(matrix_to_euler(bad, R, out), t2m::Error);
}

TEST(SimRetarget, QposToMotionMatchesMujocoKinematics) {
  // motion_from_qpos + the skeleton's FK (independent code) reproduce MuJoCo's body positions exactly.
  const auto& h = *humanoid();
  const QposTrajectory q = random_trajectory(h, 5, 11);
  const Motion mo = motion_from_qpos(h, q);
  const std::vector<float> p = replay_joint_positions(h, q);
  ASSERT_EQ(p.size(), mo.pos.size());
  for (size_t i = 0; i < p.size(); ++i) EXPECT_NEAR(p[i], mo.pos[i], 2e-5) << i;
}

TEST(SimRetarget, RetargetInvertsMotionFromQpos) {
  const auto& h = *humanoid();
  QposTrajectory q = random_trajectory(h, 4, 5);
  const Motion mo = motion_from_qpos(h, q);
  const QposTrajectory back = retarget(h, mo);
  EXPECT_EQ(back.clamped, 0);
  for (int t = 0; t < q.frames; ++t) {
    for (int k = 0; k < kHumanoidHinges; ++k) {
      const int a = h.hinge_qpos(k);
      EXPECT_NEAR(back.qpos[(size_t)t * q.nq + a], q.qpos[(size_t)t * q.nq + a], 1e-5) << t << " hinge " << k;
    }
    // Root: same position up to the floor shift, same rotation up to quaternion sign.
    double dot = 0;
    for (int k = 3; k < 7; ++k) dot += back.qpos[(size_t)t * q.nq + k] * q.qpos[(size_t)t * q.nq + k];
    EXPECT_NEAR(std::abs(dot), 1.0, 1e-6);
    EXPECT_NEAR(back.qpos[(size_t)t * q.nq + 2] - back.floor_shift, q.qpos[(size_t)t * q.nq + 2], 1e-5);
  }
  EXPECT_LT(replay_error(h, back, mo).mean_m, 1e-4);
}

TEST(SimRetarget, RestPoseIsZeroHinges) {
  // The humanoid's qpos0 (reference pose) retargets to zero hinge angles and an identity root.
  const auto& h = *humanoid();
  QposTrajectory q;
  q.frames = 1;
  q.nq = h.model()->nq;
  q.qpos.assign(h.model()->qpos0, h.model()->qpos0 + q.nq);
  const QposTrajectory back = retarget(h, motion_from_qpos(h, q));
  for (int k = 0; k < kHumanoidHinges; ++k) EXPECT_NEAR(back.qpos[h.hinge_qpos(k)], 0.0, 1e-5);
  EXPECT_NEAR(back.qpos[3], 1.0, 1e-6);
  EXPECT_NEAR(back.qpos[2], humanoid_hips_height(), 1e-4);  // soles on the floor
}

TEST(SimRetarget, RealClipReplaysWithinOneCentimetre) {
  const auto& h = *humanoid();
  const Motion mo = motion_from_bvh(parse_bvh(kWalkBvh, "walk_fixture"));
  const QposTrajectory q = retarget(h, mo);
  ASSERT_EQ(q.frames, 2);
  const ReplayError e = replay_error(h, q, mo);
  EXPECT_LT(e.mean_m, 0.01);
  EXPECT_LT(std::abs(q.floor_shift), 0.03);  // the data's soles are already near z = 0
  // Walking forward along +x in the world: the root advances by about 1.4 m over 57 frames.
  EXPECT_NEAR(q.qpos[q.nq + 0] - q.qpos[0], 1.38, 0.05);
  // The root's forward (x) axis points along the walking direction.
  double R[9];
  mju_quat2Mat(R, q.qpos.data() + 3);
  EXPECT_GT(R[0], 0.9);
  // The observation sequence is finite and shows a root height near the standing one.
  const auto obs = replay_observations(h, q);
  ASSERT_EQ(obs.size(), (size_t)2 * 313);
  for (float v : obs) ASSERT_TRUE(std::isfinite(v));
  EXPECT_NEAR(obs[0], humanoid_hips_height(), 0.05);
}

TEST(SimRetarget, BadInputThrows) {
  const auto& h = *humanoid();
  Motion bad;
  bad.frames = 2;  // sizes do not match
  EXPECT_THROW(retarget(h, bad), t2m::Error);
  QposTrajectory q;
  q.frames = 3;
  q.nq = 5;
  EXPECT_THROW(motion_from_qpos(h, q), t2m::Error);
  EXPECT_THROW(replay_joint_positions(h, q), t2m::Error);
  auto box = Humanoid::from_xml("<mujoco><worldbody><body><freejoint/><geom size='0.1'/></body></worldbody></mujoco>");
  EXPECT_THROW(retarget(*box, motion_from_qpos(h, random_trajectory(h, 1, 1))), t2m::Error);
}

TEST(SimRetarget, TrajectoryJsonRoundTripAndErrors) {
  const auto& h = *humanoid();
  const QposTrajectory q = random_trajectory(h, 3, 9);
  const std::string path = testing::TempDir() + "/t2m_traj.json";
  save_trajectory_json(q, path);
  const QposTrajectory b = load_trajectory_json(h, path);
  EXPECT_EQ(b.frames, 3);
  EXPECT_EQ(b.qpos, q.qpos);
  EXPECT_EQ(b.qvel, q.qvel);
  auto write = [&](const std::string& text) { std::ofstream(path) << text; };
  write("{not json");
  EXPECT_THROW(load_trajectory_json(h, path), t2m::Error);
  write(R"({"format": "t2m-qpos-1", "fps": 30, "nq": 5, "nv": 4, "frames": 1, "qpos": [0, 0, 0, 0, 0]})");
  EXPECT_THROW(load_trajectory_json(h, path), t2m::Error);  // not the humanoid's nq
  write(R"({"format": "other"})");
  EXPECT_THROW(load_trajectory_json(h, path), t2m::Error);
  std::remove(path.c_str());
  EXPECT_THROW(load_trajectory_json(h, path), t2m::Error);  // missing file
}
