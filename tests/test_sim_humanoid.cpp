// test_sim_humanoid.cpp — our generated MJCF humanoid: topology, rest pose, masses, limits, model loading errors.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "sim/humanoid.h"
#include "sim/skeleton.h"
#include "tensor/tensor.h"

using namespace t2m::sim;

TEST(SimHumanoid, TopologyMatchesSkeleton) {
  auto h = Humanoid::create();
  const mjModel* m = h->model();
  ASSERT_TRUE(h->is_humanoid());
  EXPECT_EQ(m->nbody, 22);  // world + 21
  EXPECT_EQ(m->nq, 7 + kHumanoidHinges);
  EXPECT_EQ(m->nv, 6 + kHumanoidHinges);
  EXPECT_EQ(m->nu, kHumanoidHinges);
  EXPECT_NEAR(m->opt.timestep, 1.0 / 450.0, 1e-9);
  for (int j = 0; j < kNumJoints; ++j) {
    const int b = h->tracked_bodies()[j];
    EXPECT_STREQ(mj_id2name(m, mjOBJ_BODY, b), kJointNames[j]);
    const int p = kJointParents[j];
    EXPECT_EQ(m->body_parentid[b], p < 0 ? 0 : h->tracked_bodies()[p]) << kJointNames[j];
    if (j > 0) {
      EXPECT_EQ(m->body_jntnum[b], 3) << kJointNames[j];
    }
  }
  EXPECT_EQ(h->root_qpos(), 0);
}

TEST(SimHumanoid, BoneLengthsMatchBandaiOffsets) {
  // Rest bone length == |BVH OFFSET| / 100 for every joint (the body positions are built from them).
  auto h = Humanoid::create();
  const mjModel* m = h->model();
  const auto& spec = humanoid_joint_spec();
  for (int j = 1; j < kNumJoints; ++j) {
    const double* p = m->body_pos + 3 * h->tracked_bodies()[j];
    const double len = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    const double* o = spec[j].offset_bvh_cm;
    EXPECT_NEAR(len, std::sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]) / 100.0, 1e-5) << spec[j].name;
  }
  // Thigh and shin about 0.39 / 0.41 m, standing hips height about 0.9 m.
  EXPECT_NEAR(humanoid_hips_height(), 0.91, 0.03);
}

TEST(SimHumanoid, MassAndInertiaAreHumanLike) {
  auto h = Humanoid::create();
  const mjModel* m = h->model();
  const double total = model_total_mass(m);
  EXPECT_GT(total, 50.0);
  EXPECT_LT(total, 85.0);
  for (int b = 1; b < m->nbody; ++b) {
    EXPECT_GT(m->body_mass[b], 0.1) << mj_id2name(m, mjOBJ_BODY, b);
    for (int k = 0; k < 3; ++k) EXPECT_GT(m->body_inertia[3 * b + k], 0.0);
  }
  // Left/right symmetry of masses.
  const int ul = mj_name2id(m, mjOBJ_BODY, "UpperLeg_L"), ur = mj_name2id(m, mjOBJ_BODY, "UpperLeg_R");
  EXPECT_NEAR(m->body_mass[ul], m->body_mass[ur], 0.05);
}

TEST(SimHumanoid, StandsOnItsSolesAtRest) {
  // At qpos0 the lowest geom point touches the floor (within 2 mm) and only sole geoms are near it.
  auto h = Humanoid::create();
  const mjModel* m = h->model();
  mjData* d = mj_makeData(m);
  mj_forward(m, d);
  EXPECT_GE(d->ncon, 2);
  for (int c = 0; c < d->ncon; ++c) {
    const int g = d->contact[c].geom1 == 0 ? d->contact[c].geom2 : d->contact[c].geom1;
    const std::string name = mj_id2name(m, mjOBJ_GEOM, g);
    EXPECT_TRUE(name.find("Foot") != std::string::npos || name.find("Toes") != std::string::npos) << name;
    EXPECT_GT(d->contact[c].dist, -0.01) << name;
  }
  mj_deleteData(d);
}

TEST(SimHumanoid, JointLimitsAndActuatorsAgree) {
  auto h = Humanoid::create();
  const mjModel* m = h->model();
  for (int k = 0; k < kHumanoidHinges; ++k) {
    const int jid = m->actuator_trnid[2 * k];
    EXPECT_EQ(m->jnt_qposadr[jid], h->hinge_qpos(k));
    EXPECT_TRUE(m->jnt_limited[jid]);
    EXPECT_LT(m->jnt_range[2 * jid], 0.0);
    EXPECT_GT(m->jnt_range[2 * jid + 1], 0.0);  // the reference pose is inside every range
    EXPECT_DOUBLE_EQ(m->actuator_ctrlrange[2 * k], m->jnt_range[2 * jid]);
    EXPECT_DOUBLE_EQ(m->actuator_ctrlrange[2 * k + 1], m->jnt_range[2 * jid + 1]);
    EXPECT_GT(m->dof_damping[m->jnt_dofadr[jid]], 0.0);
  }
  // Knee flexion (y) allows > 100 degrees.
  const int knee = mj_name2id(m, mjOBJ_JOINT, "LowerLeg_L_y");
  ASSERT_GE(knee, 0);
  EXPECT_GT(m->jnt_range[2 * knee + 1], 100 * M_PI / 180);
}

TEST(SimHumanoid, BadModelInputsThrow) {
  EXPECT_THROW(Humanoid::from_file("/nonexistent/model.xml"), t2m::Error);
  EXPECT_THROW(Humanoid::from_xml("<mujoco><worldbody><geom type=\"nosuch\"/></worldbody></mujoco>"), t2m::Error);
  EXPECT_THROW(Humanoid::from_xml("this is not xml"), t2m::Error);
  const std::string path = testing::TempDir() + "/t2m_bad_model.xml";
  { std::ofstream(path) << "<mujoco><worldbody><body><joint type=\"hinge\"/></body></worldbody>"; }
  EXPECT_THROW(Humanoid::from_file(path), t2m::Error);
  std::remove(path.c_str());
  HumanoidOptions bad;
  bad.solver_iterations = 0;
  EXPECT_THROW(humanoid_mjcf(bad), t2m::Error);
  HumanoidOptions bad_solver;
  bad_solver.solver = 99;
  EXPECT_THROW(humanoid_mjcf(bad_solver), t2m::Error);
}

TEST(SimHumanoid, FileRoundTrip) {
  const std::string path = testing::TempDir() + "/t2m_humanoid.xml";
  { std::ofstream(path) << humanoid_mjcf(); }
  auto h = Humanoid::from_file(path);
  EXPECT_TRUE(h->is_humanoid());
  EXPECT_EQ(h->model()->nu, kHumanoidHinges);
  std::remove(path.c_str());
}

TEST(SimHumanoid, FloorPairsGiveTheSameContactsAsDynamicCollision) {
  // Our model lists the body-floor contacts as explicit pairs (collision="predefined", no broadphase). The same
  // model with dynamic (contype/conaffinity) collision instead must produce the same contacts and motion while the
  // humanoid stands, tips over and lands on the floor (2 s from a tilted standing pose, PD holding qpos0).
  const std::string xml = humanoid_mjcf();
  std::string dyn = xml;
  const std::string opt = " collision=\"predefined\"";
  ASSERT_NE(dyn.find(opt), std::string::npos);
  dyn.erase(dyn.find(opt), opt.size());
  const size_t c0 = dyn.find("  <contact>"), c1 = dyn.find("</contact>\n");
  ASSERT_NE(c0, std::string::npos);
  ASSERT_NE(c1, std::string::npos);
  dyn.erase(c0, c1 + 11 - c0);
  auto hp = Humanoid::from_xml(xml), hd = Humanoid::from_xml(dyn);
  const mjModel *mp = hp->model(), *md = hd->model();
  ASSERT_EQ(mp->npair, mp->ngeom - 1);  // every body geom against the floor
  ASSERT_EQ(md->npair, 0);
  mjData *dp = mj_makeData(mp), *dd = mj_makeData(md);
  for (mjData* d : {dp, dd}) {
    d->qpos[2] += 0.02;
    d->qpos[4] = 0.05;  // small tilt about x (quaternion x component; MuJoCo normalises it)
  }
  int max_con = 0, body_con = 0;
  double max_diff = 0;
  for (int s = 0; s < 900; ++s) {
    mj_step(mp, dp);
    mj_step(md, dd);
    ASSERT_EQ(dp->ncon, dd->ncon) << "step " << s;
    max_con = std::max(max_con, dp->ncon);
    for (int c = 0; c < dp->ncon; ++c) {
      const std::string name = mj_id2name(mp, mjOBJ_GEOM, dp->contact[c].geom2);
      if (name.find("Foot") == std::string::npos && name.find("Toes") == std::string::npos) ++body_con;
    }
    for (int i = 0; i < mp->nq; ++i) max_diff = std::max(max_diff, std::abs(dp->qpos[i] - dd->qpos[i]));
  }
  std::printf("max |qpos diff| %.3g, max contacts %d, non-foot contacts %d\n", max_diff, max_con, body_con);
  EXPECT_LT(max_diff, 1e-6);
  EXPECT_GE(max_con, 6);    // both feet (and toes) on the floor at some point
  EXPECT_GT(body_con, 0);   // and it fell: contacts of non-foot bodies were compared too
  mj_deleteData(dp);
  mj_deleteData(dd);
}
