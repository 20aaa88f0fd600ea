// test_sim_balance.cpp — the balance-feedback expert tracker (sim/balance_tracker.h): reference quantities, the
// virtual-force signs, the no-contact fallback to PD, and that it keeps standing where plain PD tips over.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/balance_tracker.h"
#include "sim/skeleton.h"
#include "tensor/tensor.h"

using namespace t2m::sim;

namespace {
std::shared_ptr<const Humanoid> humanoid() {
  static auto h = Humanoid::create();
  return h;
}
// The reference pose held still for `frames` frames, hips at `z`.
QposTrajectory standing(const Humanoid& h, int frames, double z) {
  QposTrajectory q;
  q.frames = frames;
  q.nq = h.model()->nq;
  for (int t = 0; t < frames; ++t) {
    q.qpos.insert(q.qpos.end(), h.model()->qpos0, h.model()->qpos0 + q.nq);
    q.qpos[(size_t)t * q.nq + 2] = z;
  }
  trajectory_velocities(h, q);
  return q;
}
// PD-only targets of frame t (what balance_targets adds to).
std::vector<double> pd_targets(const mjModel* m, const QposTrajectory& q, int t) {
  std::vector<double> c(m->nu);
  for (int k = 0; k < m->nu; ++k) {
    const int jid = m->actuator_trnid[2 * k], dof = m->jnt_dofadr[jid];
    const double kp = m->actuator_gainprm[mjNGAIN * k];
    c[k] = std::clamp(q.qpos[(size_t)t * q.nq + m->jnt_qposadr[jid]] + m->dof_damping[dof] / kp * q.qvel[(size_t)t * q.nv + dof],
                      m->actuator_ctrlrange[2 * k], m->actuator_ctrlrange[2 * k + 1]);
  }
  return c;
}
}  // namespace

TEST(SimBalance, ReferenceQuantities) {
  // A reference translating at 0.3 m/s along x: the centre of mass moves with it, no rotation.
  const Humanoid& h = *humanoid();
  QposTrajectory q = standing(h, 6, humanoid_hips_height());
  for (int t = 0; t < 6; ++t) q.qpos[(size_t)t * q.nq] = 0.01 * t;
  trajectory_velocities(h, q);
  const BalanceReference r = balance_reference(h, q);
  ASSERT_EQ(r.frames, 6);
  for (int t = 0; t < 6; ++t) {
    EXPECT_NEAR(r.com_vel[3 * t], 0.3, 1e-9);
    EXPECT_NEAR(r.com_vel[3 * t + 1], 0.0, 1e-9);
    EXPECT_NEAR(r.com[3 * t] - r.com[0], 0.01 * t, 1e-9);
    EXPECT_NEAR(r.root_quat[4 * t], 1.0, 1e-9);
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(r.root_angvel[3 * t + i], 0.0, 1e-9);
  }
  const BalanceFrame f = r.frame(q, 2);
  EXPECT_EQ(f.qpos, q.qpos.data() + 2 * q.nq);
  EXPECT_EQ(f.com, r.com.data() + 6);
  EXPECT_THROW(r.frame(q, 6), t2m::Error);
  EXPECT_THROW(r.frame(q, -1), t2m::Error);
  QposTrajectory shorter = standing(h, 5, humanoid_hips_height());
  EXPECT_THROW(r.frame(shorter, 1), t2m::Error);
  shorter.qvel.pop_back();
  EXPECT_THROW(balance_reference(h, shorter), t2m::Error);
}

TEST(SimBalance, NoContactMeansPlainPd) {
  // In the air (hips 0.5 m above standing height) no leg is in stance: the targets are the PD targets.
  const double z = humanoid_hips_height() + 0.5;
  const QposTrajectory q = standing(*humanoid(), 3, z);
  Env env(humanoid());
  env.reset(q.qpos.data(), q.qvel.data(), nullptr);
  const BalanceReference r = balance_reference(*humanoid(), q);
  std::vector<double> c(env.action_dim());
  balance_targets(env, r.frame(q, 1), BalanceOptions{}, c.data());
  const std::vector<double> pd = pd_targets(env.model(), q, 1);
  for (int k = 0; k < env.action_dim(); ++k) EXPECT_DOUBLE_EQ(c[k], pd[k]) << k;
}

TEST(SimBalance, VirtualForcePushesTheBodyTowardsTheReference) {
  // Standing, with the reference 10 cm ahead (+x): the stance ankles must pitch the shins forward, i.e. the
  // ankle flexion (y hinge) target moves in the direction that rotates the shin towards +x relative to the foot,
  // and the left-right (roll) targets barely move. Same with the reference behind: the opposite sign.
  const Humanoid& h = *humanoid();
  const double z = humanoid_hips_height();
  Env env(humanoid());
  const QposTrajectory here = standing(h, 3, z);
  env.reset(here.qpos.data(), here.qvel.data(), nullptr);
  ASSERT_GT(env.data()->ncon, 0);
  BalanceOptions o;
  o.root_kp = o.root_kd = 0;  // isolate the force
  double shift[2];
  for (int s = 0; s < 2; ++s) {
    QposTrajectory q = standing(h, 3, z);
    for (int t = 0; t < 3; ++t) q.qpos[(size_t)t * q.nq] = s == 0 ? 0.1 : -0.1;
    trajectory_velocities(h, q);
    const BalanceReference r = balance_reference(h, q);
    std::vector<double> c(env.action_dim());
    balance_targets(env, r.frame(q, 1), o, c.data());
    const std::vector<double> pd = pd_targets(env.model(), q, 1);
    // the left ankle's hinges: body Foot_L = joint kFootL, hinges 3 (kFootL - 1) .. + 2; find the y axis one
    const mjModel* m = env.model();
    double dy = 0, dx = 0;
    for (int i = 0; i < 3; ++i) {
      const int k = 3 * (kFootL - 1) + i, jn = m->actuator_trnid[2 * k];
      if (m->jnt_axis[3 * jn + 1] > 0.9) dy = c[k] - pd[k];
      if (m->jnt_axis[3 * jn] > 0.9) dx = c[k] - pd[k];
    }
    shift[s] = dy;
    EXPECT_GT(std::fabs(dy), 5 * std::fabs(dx));
  }
  // Rotating the shin towards +x about the ankle's y axis is a negative foot rotation relative to the shin.
  EXPECT_LT(shift[0], -1e-3);
  EXPECT_GT(shift[1], 1e-3);
}

TEST(SimBalance, KeepsStandingWherePdTipsOver) {
  // The reference pose held for 4 s: plain PD tips over (the pose's centre of mass is near the front of the feet),
  // the balance feedback keeps it within the 0.5 m tracking bound.
  const QposTrajectory q = standing(*humanoid(), 120, humanoid_hips_height());
  Env env(humanoid());
  const PdResult pd = track_pd(env, q);
  const PdResult bal = track_balance(env, q);
  std::printf("standing 4 s: PD frames ok %d (fell %d, drift %.2f m), balance %d (fell %d, drift %.2f m)\n",
              pd.frames_ok, (int)pd.fell, pd.root_drift_m, bal.frames_ok, (int)bal.fell, bal.root_drift_m);
  EXPECT_FALSE(pd.success);
  EXPECT_TRUE(bal.success);
  EXPECT_FALSE(bal.fell);
  EXPECT_LT(bal.root_drift_m, 0.2);
}

TEST(SimBalance, TorqueAtHipsOnlyLeavesKneesAndAnklesAlone) {
  // Orientation feedback only (no force): a reference pitched 0.1 rad forward. With torque_at_hips_only the knee and
  // ankle targets stay the PD targets and the hips move; without it the ankles move too.
  const Humanoid& h = *humanoid();
  Env env(humanoid());
  const QposTrajectory here = standing(h, 3, humanoid_hips_height());
  env.reset(here.qpos.data(), here.qvel.data(), nullptr);
  QposTrajectory q = here;
  for (int t = 0; t < 3; ++t) {  // root quaternion: rotation of 0.1 rad about y
    double* p = q.qpos.data() + (size_t)t * q.nq + 3;
    p[0] = std::cos(0.05), p[1] = 0, p[2] = std::sin(0.05), p[3] = 0;
  }
  trajectory_velocities(h, q);
  const BalanceReference r = balance_reference(h, q);
  const std::vector<double> pd = pd_targets(env.model(), q, 1);
  BalanceOptions o;
  o.com_kp = o.com_kd = 0;
  for (bool hips_only : {true, false}) {
    o.torque_at_hips_only = hips_only;
    std::vector<double> c(env.action_dim());
    balance_targets(env, r.frame(q, 1), o, c.data());
    double hip = 0, knee_ankle = 0;
    for (int j : {kUpperLegL, kUpperLegR})
      for (int i = 0; i < 3; ++i) hip += std::fabs(c[3 * (j - 1) + i] - pd[3 * (j - 1) + i]);
    for (int j : {kLowerLegL, kLowerLegR, kFootL, kFootR})
      for (int i = 0; i < 3; ++i) knee_ankle += std::fabs(c[3 * (j - 1) + i] - pd[3 * (j - 1) + i]);
    EXPECT_GT(hip, 1e-3) << hips_only;
    if (hips_only) EXPECT_EQ(knee_ankle, 0.0);
    else EXPECT_GT(knee_ankle, 1e-3);
  }
}

TEST(SimBalance, ActionNoiseIsSeededAndPerturbsTheExpert) {
  // 2 s of standing: the noise changes the motion, the same seed repeats it bit for bit, another seed differs,
  // noise 0 is the noiseless expert whatever the seed, and large noise breaks the stand the expert otherwise keeps.
  const QposTrajectory q = standing(*humanoid(), 60, humanoid_hips_height());
  Env env(humanoid());
  const PdResult clean = track_balance(env, q);
  BalanceOptions o;
  o.noise_seed = 7;
  EXPECT_EQ(track_balance(env, q, o).mpjpe_m, clean.mpjpe_m);
  o.action_noise = 0.05;
  const PdResult a = track_balance(env, q, o), b = track_balance(env, q, o);
  EXPECT_EQ(a.mpjpe_m, b.mpjpe_m);
  EXPECT_NE(a.mpjpe_m, clean.mpjpe_m);
  o.noise_seed = 8;
  EXPECT_NE(track_balance(env, q, o).mpjpe_m, a.mpjpe_m);
  o.action_noise = 0.5;
  EXPECT_TRUE(clean.success);
  EXPECT_FALSE(track_balance(env, q, o).success);
  o.action_noise = -1;
  EXPECT_THROW(track_balance(env, q, o), t2m::Error);
}
