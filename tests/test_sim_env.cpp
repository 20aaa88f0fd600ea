// test_sim_env.cpp — Env / VecEnv / observation on small inline MJCF fixtures and on our humanoid.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <new>
#include <vector>

#include "sim/env.h"
#include "sim/observation.h"
#include "tensor/tensor.h"

using namespace t2m::sim;

// Counts every operator new of this test program, to check that stepping allocates nothing.
static std::atomic<long> g_news{0};
void* operator new(std::size_t n) {
  ++g_news;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace {
const char* kBoxXml = R"(
<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="box" pos="0 0 1">
      <freejoint/>
      <geom type="box" size="0.1 0.1 0.1" mass="1"/>
    </body>
  </worldbody>
</mujoco>)";

// A pendulum-free arm: one hinge about z (no gravity torque), position actuator with ctrlrange [-0.5, 1.5] rad.
const char* kArmXml = R"(
<mujoco>
  <compiler angle="radian"/>
  <option timestep="0.002" gravity="0 0 0"/>
  <worldbody>
    <body name="base" pos="0 0 1">
      <joint name="hinge" type="hinge" axis="0 0 1" damping="2" limited="true" range="-1 2"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.05" mass="1"/>
      <body name="tip" pos="0.5 0 0">
        <geom type="sphere" size="0.05" mass="0.1"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position joint="hinge" kp="20" ctrllimited="true" ctrlrange="-0.5 1.5"/>
  </actuator>
</mujoco>)";

// Two bodies: a free root and a child 1 m ahead along the root's x axis and 0.5 m up.
const char* kPairXml = R"(
<mujoco>
  <option gravity="0 0 0"/>
  <worldbody>
    <body name="root" pos="0 0 0">
      <freejoint/>
      <geom type="sphere" size="0.1"/>
      <body name="child" pos="1 0 0.5">
        <geom type="sphere" size="0.1"/>
      </body>
    </body>
  </worldbody>
</mujoco>)";
}  // namespace

TEST(SimEnv, DroppedBoxComesToRest) {
  Env env(Humanoid::from_xml(kBoxXml), EnvOptions{.substeps = 10});
  std::vector<float> obs(env.obs_dim());
  env.reset(nullptr, nullptr, obs.data());
  EXPECT_NEAR(obs[0], 1.0, 1e-6);  // root height
  for (int t = 0; t < 100; ++t) env.step(nullptr, obs.data());  // no actuators: action_dim() == 0
  EXPECT_NEAR(obs[0], 0.1, 0.005);  // resting on its face
  const auto L = observation_layout(1);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(obs[L.lin_vel + k], 0.0, 1e-2);
    EXPECT_NEAR(obs[L.ang_vel + k], 0.0, 1e-2);
  }
}

TEST(SimEnv, ActuatorSignAndRange) {
  Env env(Humanoid::from_xml(kArmXml), EnvOptions{.substeps = 50});
  ASSERT_EQ(env.action_dim(), 1);
  EXPECT_DOUBLE_EQ(env.action_to_ctrl(0, -1.0), -0.5);
  EXPECT_DOUBLE_EQ(env.action_to_ctrl(0, 1.0), 1.5);
  EXPECT_DOUBLE_EQ(env.action_to_ctrl(0, 0.0), 0.5);
  EXPECT_DOUBLE_EQ(env.action_to_ctrl(0, 7.0), 1.5);  // clamped
  EXPECT_NEAR(env.ctrl_to_action(0, env.action_to_ctrl(0, 0.3)), 0.3, 1e-12);
  for (float a : {1.0f, -1.0f, 0.0f}) {
    env.reset(nullptr, nullptr, nullptr);
    for (int t = 0; t < 40; ++t) env.step(&a, nullptr);  // 4 s
    EXPECT_NEAR(env.data()->qpos[0], env.action_to_ctrl(0, a), 0.01) << "action " << a;
    // Positive hinge angle about +z turns the tip towards +y.
    const double tip_y = env.data()->xpos[3 * 2 + 1];
    EXPECT_EQ(tip_y > 0.01, env.data()->qpos[0] > 0.02);
  }
}

TEST(SimEnv, ObservationLayoutInHeadingFrame) {
  Env env(Humanoid::from_xml(kPairXml));
  ASSERT_EQ(env.obs_dim(), observation_dim(2));
  const double yaw = M_PI / 2;  // root faces +y
  std::vector<double> qpos = {3, 4, 2, std::cos(yaw / 2), 0, 0, std::sin(yaw / 2)};
  std::vector<double> qvel = {1, 0, 0, 0, 0, 0.5};  // world +x velocity, yaw rate 0.5 rad/s
  std::vector<float> obs(env.obs_dim());
  env.reset(qpos.data(), qvel.data(), obs.data());
  const auto L = observation_layout(2);
  EXPECT_EQ(L.dim, 1 + 3 + 24);
  EXPECT_NEAR(obs[L.root_height], 2.0, 1e-6);
  // Child relative position in the heading frame is the body-frame offset (1, 0, 0.5).
  EXPECT_NEAR(obs[L.rel_pos + 0], 1.0, 1e-6);
  EXPECT_NEAR(obs[L.rel_pos + 1], 0.0, 1e-6);
  EXPECT_NEAR(obs[L.rel_pos + 2], 0.5, 1e-6);
  // Root orientation in the heading frame is the identity: columns (1,0,0), (0,1,0).
  const float id6[6] = {1, 0, 0, 0, 1, 0};
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(obs[L.rot6d + k], id6[k], 1e-6);
  // World +x velocity seen from a frame facing +y is -y.
  EXPECT_NEAR(obs[L.lin_vel + 0], 0.0, 1e-6);
  EXPECT_NEAR(obs[L.lin_vel + 1], -1.0, 1e-6);
  EXPECT_NEAR(obs[L.ang_vel + 2], 0.5, 1e-6);
  // The child (1 m ahead of the root) moves with v + w x r: heading-frame (0, -1, 0) + 0.5 z x (1, 0, 0.5).
  EXPECT_NEAR(obs[L.lin_vel + 3 + 0], 0.0, 1e-6);
  EXPECT_NEAR(obs[L.lin_vel + 3 + 1], -1.0 + 0.5, 1e-6);
  EXPECT_NEAR(obs[L.ang_vel + 3 + 2], 0.5, 1e-6);
}

TEST(SimEnv, BadInputsThrow) {
  auto h = Humanoid::from_xml(kArmXml);
  Env env(h);
  float nan = std::nanf("");
  EXPECT_THROW(env.step(&nan, nullptr), t2m::Error);
  double bad = INFINITY;
  EXPECT_THROW(env.step_targets(&bad, nullptr), t2m::Error);
  double qbad = NAN;
  EXPECT_THROW(env.reset(&qbad, nullptr, nullptr), t2m::Error);
  EXPECT_THROW(Env(h, EnvOptions{.substeps = 0}), t2m::Error);
  VecEnv venv(h, 3);
  std::vector<float> acts = {0.f, nan, 0.f};
  EXPECT_THROW(venv.step(acts.data(), nullptr), t2m::Error);
  EXPECT_THROW(VecEnv(h, 0), t2m::Error);
}

TEST(SimEnv, HumanoidVecEnvMatchesSerialAndStaysFinite) {
  auto h = Humanoid::create();
  const int N = 4;
  VecEnv venv(h, N);
  Env serial(h);
  ASSERT_EQ(venv.obs_dim(), 313);
  ASSERT_EQ(venv.action_dim(), 60);
  std::vector<float> obs(N * venv.obs_dim()), obs1(serial.obs_dim()), act(N * venv.action_dim());
  for (int i = 0; i < N; ++i) venv.env(i).reset(nullptr, nullptr, nullptr);
  serial.reset(nullptr, nullptr, nullptr);
  for (int t = 0; t < 10; ++t) {
    for (int i = 0; i < N; ++i)
      for (int k = 0; k < venv.action_dim(); ++k)
        act[i * venv.action_dim() + k] = 0.3f * std::sin(0.1f * (t + 1) * (k + 1) + i);
    venv.step(act.data(), obs.data());
    serial.step(act.data() + 2 * venv.action_dim(), obs1.data());  // same actions as env 2
  }
  for (int k = 0; k < serial.obs_dim(); ++k) {
    ASSERT_TRUE(std::isfinite(obs[k]));
    EXPECT_EQ(obs[2 * venv.obs_dim() + k], obs1[k]) << k;  // bitwise identical: envs are independent
  }
  EXPECT_NEAR(venv.env(0).data()->time, 10 * kControlDt, 1e-9);
}

TEST(SimEnv, StepAllocatesNothing) {
  auto h = Humanoid::create();
  VecEnv venv(h, 2);
  std::vector<float> act(2 * venv.action_dim(), 0.1f), obs(2 * venv.obs_dim());
  for (int i = 0; i < 2; ++i) venv.env(i).reset(nullptr, nullptr, nullptr);
  venv.step(act.data(), obs.data());  // warm-up (OpenMP thread pool start)
  const long before = g_news.load();
  for (int t = 0; t < 5; ++t) venv.step(act.data(), obs.data());
  std::vector<double> ctrl(venv.action_dim(), 0.0);
  const long mid = g_news.load();  // the vector above allocated once
  venv.env(0).step_targets(ctrl.data(), obs.data());
  EXPECT_EQ(mid - before, 1);
  EXPECT_EQ(g_news.load(), mid);
}

TEST(SimEnv, HumanoidBodyVelocitiesMatchFiniteDifferences) {
  // Linear / angular body velocities in the observation agree with finite differences of the kinematics.
  auto h = Humanoid::create();
  const mjModel* m = h->model();
  Env env(h);
  std::vector<double> qvel(m->nv);
  for (int i = 0; i < m->nv; ++i) qvel[i] = 0.5 * std::sin(1.7 * i + 0.3);
  std::vector<float> obs(env.obs_dim());
  env.reset(m->qpos0, qvel.data(), obs.data());  // root at identity: heading frame = world axes
  const double eps = 1e-6;
  mjData* a = mj_makeData(m);
  mjData* b = mj_makeData(m);
  mju_copy(a->qpos, m->qpos0, m->nq);
  mju_copy(b->qpos, m->qpos0, m->nq);
  mj_integratePos(m, a->qpos, qvel.data(), -eps);
  mj_integratePos(m, b->qpos, qvel.data(), eps);
  mj_kinematics(m, a);
  mj_kinematics(m, b);
  const auto L = observation_layout(21);
  for (int j = 0; j < 21; ++j) {
    const int body = h->tracked_bodies()[j];
    for (int k = 0; k < 3; ++k) {
      const double v = (b->xpos[3 * body + k] - a->xpos[3 * body + k]) / (2 * eps);
      EXPECT_NEAR(obs[L.lin_vel + 3 * j + k], v, 1e-4 * (1 + std::abs(v))) << "body " << j << " axis " << k;
    }
    // Angular velocity from dR/dt R^T (world frame): w = vee((Rb - Ra) / 2eps * R^T).
    double R[9], dR[9], W[9];
    mju_copy(R, env.data()->xmat + 9 * body, 9);
    for (int k = 0; k < 9; ++k) dR[k] = (b->xmat[9 * body + k] - a->xmat[9 * body + k]) / (2 * eps);
    mju_mulMatMatT(W, dR, R, 3, 3, 3);
    const double w[3] = {W[7], W[2], W[3]};
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(obs[L.ang_vel + 3 * j + k], w[k], 1e-4 * (1 + std::abs(w[k]))) << "body " << j << " axis " << k;
  }
  mj_deleteData(a);
  mj_deleteData(b);
}
