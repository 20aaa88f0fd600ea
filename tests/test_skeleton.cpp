// test_skeleton.cpp — canonical skeleton and FK: hand-computed poses of a small chain, Euler <-> quaternion
// against rotation matrices built here, the Y-up cm -> Z-up m basis change, the real clip against an independent
// matrix FK written in this file, physical sanity of the result (height, forward, left), Motion -> BVH -> Motion.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>

#include "sim/bvh.h"
#include "sim/skeleton.h"
#include "tensor/tensor.h"

using namespace t2m;
using namespace t2m::sim;

namespace {

std::string fixture(const std::string& name) { return std::string(T2M_SOURCE_DIR) + "/tests/fixtures/bvh/" + name; }

using Mat = std::array<std::array<double, 3>, 3>;
Mat mmul(const Mat& a, const Mat& b) {
  Mat c{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) c[i][j] += a[i][k] * b[k][j];
  return c;
}
Mat elementary(int axis, double deg) {
  const double r = deg * M_PI / 180, c = std::cos(r), s = std::sin(r);
  Mat m{};
  const int a = (axis + 1) % 3, b = (axis + 2) % 3;
  m[axis][axis] = 1;
  m[a][a] = c, m[a][b] = -s, m[b][a] = s, m[b][b] = c;
  return m;
}
Mat quat_to_mat(const double q[4]) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  return Mat{{{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
              {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
              {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}}};
}
std::array<double, 3> mat_apply(const Mat& m, const double v[3]) {
  return {m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2], m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
          m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2]};
}

// Independent reference: BVH FK with rotation matrices (position channels replace OFFSET), BVH units.
std::vector<std::array<double, 3>> reference_bvh_fk(const BvhMotion& b, int t) {
  const int J = (int)b.joints.size();
  std::vector<Mat> W(J);
  std::vector<std::array<double, 3>> P(J);
  const double* row = b.frame(t);
  for (int j = 0, c = 0; j < J; ++j) {
    const BvhJoint& bj = b.joints[j];
    double tr[3] = {bj.offset[0], bj.offset[1], bj.offset[2]};
    Mat R{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
    for (Channel ch : bj.channels) {
      const double v = row[c++];
      if (is_rotation(ch)) {
        R = mmul(R, elementary(channel_axis(ch), v));
      } else {
        tr[channel_axis(ch)] = v;
      }
    }
    if (bj.parent < 0) {
      W[j] = R;
      P[j] = {tr[0], tr[1], tr[2]};
    } else {
      W[j] = mmul(W[bj.parent], R);
      auto r = mat_apply(W[bj.parent], tr);
      for (int k = 0; k < 3; ++k) P[j][k] = P[bj.parent][k] + r[k];
    }
  }
  return P;
}

}  // namespace

TEST(Skeleton, TablesAreConsistent) {
  for (int j = 0; j < kNumJoints; ++j) {
    EXPECT_LT(kJointParents[j], j);
    EXPECT_EQ(joint_index(kJointNames[j]), j);
    EXPECT_EQ(kJointMirror[kJointMirror[j]], j);
    std::string n = kJointNames[j], m = kJointNames[kJointMirror[j]];
    const std::string side = n.size() > 2 ? n.substr(n.size() - 2) : "";
    const std::string want = side == "_L" ? n.substr(0, n.size() - 2) + "_R"
                             : side == "_R" ? n.substr(0, n.size() - 2) + "_L"
                                            : n;
    EXPECT_EQ(m, want);
    if (j > 0) {
      EXPECT_EQ(kJointParents[kJointMirror[j]], kJointMirror[kJointParents[j]]);
    }
  }
  EXPECT_EQ(joint_index("joint_Root"), -1);
}

TEST(Skeleton, ForwardKinematicsOfHandComputedChain) {
  // chain3.bvh: Base -(10,0,0)- Mid -(0,5,0)- Tip -(0,0,2)- end. Expected positions worked out by hand.
  BvhMotion b = read_bvh(fixture("chain3.bvh"));
  ASSERT_EQ(b.frames, 3);
  const int parents[4] = {-1, 0, 1, 2};
  const float offsets[12] = {0, 0, 0, 10, 0, 0, 0, 5, 0, 0, 0, 2};
  const double want[3][4][3] = {
      {{0, 0, 0}, {10, 0, 0}, {10, 5, 0}, {10, 5, 2}},   // rest
      {{1, 2, 3}, {1, 12, 3}, {-4, 12, 3}, {-4, 12, 5}},  // root moved (1,2,3), Zrot 90: x->y, y->-x
      {{0, 0, 0}, {10, 0, 0}, {5, 0, 0}, {7, 0, 0}},      // Mid Zrot 90, Tip Xrot 90: (0,0,2) -> (0,-2,0) -> (2,0,0)
  };
  for (int t = 0; t < 3; ++t) {
    const double* row = b.frame(t);
    float rot[16];
    int c = 0;
    for (int j = 0; j < 3; ++j) {
      const BvhJoint& bj = b.joints[j];
      std::vector<Channel> order;
      std::vector<double> deg;
      for (Channel ch : bj.channels) {
        if (is_rotation(ch)) order.push_back(ch), deg.push_back(row[c]);
        ++c;
      }
      double q[4];
      quat_from_euler_deg(order.data(), deg.data(), (int)order.size(), q);
      for (int k = 0; k < 4; ++k) rot[4 * j + k] = (float)q[k];
    }
    rot[12] = 1, rot[13] = rot[14] = rot[15] = 0;  // end site: identity
    const float root[3] = {(float)row[0], (float)row[1], (float)row[2]};
    float pos[12], wrot[16];
    forward_kinematics(rot, offsets, parents, 4, root, pos, wrot);
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(pos[3 * j + k], want[t][j][k], 1e-5) << "t " << t << " j " << j;
    // World rotation of the end equals that of Tip (identity local).
    for (int k = 0; k < 4; ++k) EXPECT_FLOAT_EQ(wrot[12 + k], wrot[8 + k]);
  }
}

TEST(Skeleton, EulerQuaternionMatchesMatrixProductAndInverts) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-180, 180);
  const Channel zxy[3] = {Channel::Zrotation, Channel::Xrotation, Channel::Yrotation};
  const Channel yxz[3] = {Channel::Yrotation, Channel::Xrotation, Channel::Zrotation};
  for (int it = 0; it < 200; ++it) {
    double deg[3] = {U(rng), U(rng) / 2.1, U(rng)};  // |x| < 90 so the ZXY angles are unique
    double q[4];
    quat_from_euler_deg(zxy, deg, 3, q);
    Mat want = mmul(mmul(elementary(2, deg[0]), elementary(0, deg[1])), elementary(1, deg[2]));
    Mat got = quat_to_mat(q);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) ASSERT_NEAR(got[i][j], want[i][j], 1e-12);
    double back[3];
    quat_to_euler_zxy_deg(q, back);
    for (int k = 0; k < 3; ++k) ASSERT_NEAR(back[k], deg[k], 1e-8);
    // Another order is honoured too.
    quat_from_euler_deg(yxz, deg, 3, q);
    want = mmul(mmul(elementary(1, deg[0]), elementary(0, deg[1])), elementary(2, deg[2]));
    got = quat_to_mat(q);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) ASSERT_NEAR(got[i][j], want[i][j], 1e-12);
  }
  // Gimbal lock (x = 90): the angles differ but the rotation is the same.
  double deg[3] = {30, 90, 20}, q[4], back[3], q2[4];
  quat_from_euler_deg(zxy, deg, 3, q);
  quat_to_euler_zxy_deg(q, back);
  quat_from_euler_deg(zxy, back, 3, q2);
  EXPECT_NEAR(std::fabs(q[0] * q2[0] + q[1] * q2[1] + q[2] * q2[2] + q[3] * q2[3]), 1.0, 1e-9);
  const Channel bad[1] = {Channel::Xposition};
  EXPECT_THROW(quat_from_euler_deg(bad, deg, 1, q), Error);
}

TEST(Skeleton, BasisChangeIsAProperRotationScaledToMetres) {
  const double v[3] = {1, 2, 3};
  double w[3], back[3];
  bvh_to_world_vec(v, w);
  EXPECT_DOUBLE_EQ(w[0], 0.03);  // forward (+Z bvh) -> +X
  EXPECT_DOUBLE_EQ(w[1], 0.01);  // left (+X bvh) -> +Y
  EXPECT_DOUBLE_EQ(w[2], 0.02);  // up (+Y bvh) -> +Z
  world_to_bvh_vec(w, back);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(back[k], v[k], 1e-12);
  // Rotating then converting == converting then rotating by the converted quaternion.
  const Channel zxy[3] = {Channel::Zrotation, Channel::Xrotation, Channel::Yrotation};
  const double deg[3] = {20, -35, 70};
  double q[4], qw[4], qb[4];
  quat_from_euler_deg(zxy, deg, 3, q);
  bvh_to_world_quat(q, qw);
  world_to_bvh_quat(qw, qb);
  for (int k = 0; k < 4; ++k) EXPECT_DOUBLE_EQ(qb[k], q[k]);
  auto rv = mat_apply(quat_to_mat(q), v);
  double rvw[3];
  bvh_to_world_vec(rv.data(), rvw);
  auto wr = mat_apply(quat_to_mat(qw), w);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(rvw[k], wr[k], 1e-12);
}

TEST(Skeleton, RealClipMatchesIndependentMatrixFk) {
  BvhMotion b = read_bvh(fixture("bandai_walk_60.bvh"));
  Motion m = motion_from_bvh(b);
  ASSERT_EQ(m.frames, 60);
  EXPECT_NEAR(m.fps, 30.0, 1e-3);
  validate_motion(m, "test");
  double worst = 0;
  for (int t = 0; t < m.frames; t += 7) {
    auto P = reference_bvh_fk(b, t);
    for (int j = 0; j < kNumJoints; ++j) {
      double w[3];
      bvh_to_world_vec(P[b.find_joint(kJointNames[j])].data(), w);
      for (int k = 0; k < 3; ++k) worst = std::max(worst, std::fabs(w[k] - m.pos[(t * kNumJoints + j) * 3 + k]));
    }
  }
  EXPECT_LT(worst, 1e-4) << "metres";  // float storage + the data's position channels vs OFFSET (1e-5 cm)
}

TEST(Skeleton, RealClipIsUprightFacesForwardAndWalksAlongX) {
  Motion m = motion_from_bvh(read_bvh(fixture("bandai_walk_60.bvh")));
  auto P = [&](int t, int j, int k) { return m.pos[(t * kNumJoints + j) * 3 + k]; };
  double min_toe = 1e9;
  for (int t = 0; t < m.frames; ++t) {
    EXPECT_GT(P(t, kHips, 2), 0.75);
    EXPECT_LT(P(t, kHips, 2), 1.1);
    EXPECT_GT(P(t, kHead, 2), P(t, kHips, 2) + 0.4);
    EXPECT_GT(P(t, kShoulderL, 1), P(t, kShoulderR, 1));  // walking +X, the left side is +Y
    min_toe = std::min({min_toe, (double)P(t, kToesL, 2), (double)P(t, kToesR, 2)});
  }
  EXPECT_LT(min_toe, 0.1);
  EXPECT_GT(min_toe, -0.05);
  EXPECT_GT(P(m.frames - 1, kHips, 0) - P(0, kHips, 0), 1.0);  // ~2 s of walking forward
  EXPECT_LT(std::fabs(P(m.frames - 1, kHips, 1) - P(0, kHips, 1)), 0.3);
  // Bone lengths are constant (rigid skeleton): thigh length at two frames.
  auto bone = [&](int t, int j) {
    double s = 0;
    for (int k = 0; k < 3; ++k) s += std::pow(P(t, j, k) - P(t, kJointParents[j], k), 2);
    return std::sqrt(s);
  };
  EXPECT_NEAR(bone(0, kLowerLegL), bone(59, kLowerLegL), 1e-5);
  EXPECT_NEAR(bone(0, kLowerLegL), 0.390811, 1e-5);
}

TEST(Skeleton, MotionToBvhToMotionRoundTrip) {
  Motion a = motion_from_bvh(read_bvh(fixture("bandai_walk_60.bvh")));
  BvhMotion b = bvh_from_motion(a);
  ASSERT_EQ(b.joints.size(), 22u);
  EXPECT_EQ(b.joints[0].name, "joint_Root");
  EXPECT_TRUE(b.joints[b.find_joint("Head")].has_end_site);
  Motion c = motion_from_bvh(parse_bvh(bvh_to_string(b), "roundtrip"));
  ASSERT_EQ(c.frames, a.frames);
  EXPECT_NEAR(c.fps, a.fps, 1e-3);
  for (size_t i = 0; i < a.offsets.size(); ++i) EXPECT_NEAR(c.offsets[i], a.offsets[i], 1e-6);
  for (size_t i = 0; i < a.pos.size(); ++i) ASSERT_NEAR(c.pos[i], a.pos[i], 1e-4) << i;
  for (size_t i = 0; i < a.rot.size(); i += 4) {
    double d = 0;
    for (int k = 0; k < 4; ++k) d += (double)a.rot[i + k] * c.rot[i + k];
    ASSERT_GT(std::fabs(d), 1 - 1e-6) << i / 4;
  }
  // motion_fk reproduces pos from rot + offsets + root.
  Motion d = a;
  for (size_t i = 3; i < d.pos.size(); ++i)
    if (i % (3 * kNumJoints) >= 3) d.pos[i] = 0;
  motion_fk(d);
  for (size_t i = 0; i < a.pos.size(); ++i) ASSERT_NEAR(d.pos[i], a.pos[i], 1e-5);
}

TEST(Skeleton, RejectsBadInput) {
  BvhMotion b = read_bvh(fixture("chain3.bvh"));
  try {
    motion_from_bvh(b);
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("lacks canonical joints: Hips, Spine"), std::string::npos) << e.what();
  }
  BvhMotion r = read_bvh(fixture("bandai_walk_60.bvh"));
  BvhMotion bad = r;
  bad.joints[bad.find_joint("Toes_L")].parent = bad.find_joint("Hips");
  EXPECT_THROW(motion_from_bvh(bad), Error);
  bad = r;
  bad.values.resize(10);
  EXPECT_THROW(motion_from_bvh(bad), Error);
  Motion m = motion_from_bvh(r);
  Motion mm = m;
  mm.rot.pop_back();
  EXPECT_THROW(validate_motion(mm, "x"), Error);
  EXPECT_THROW(bvh_from_motion(mm), Error);
  mm = m;
  mm.fps = 0;
  EXPECT_THROW(bvh_from_motion(mm), Error);
  mm = m;
  mm.pos[5] = NAN;
  EXPECT_THROW(motion_fk(mm), Error);
  const int parents[2] = {-1, 1};
  float rot[8] = {1, 0, 0, 0, 1, 0, 0, 0}, off[6] = {}, root[3] = {}, pos[6];
  EXPECT_THROW(forward_kinematics(rot, off, parents, 2, root, pos), Error);
  EXPECT_THROW(forward_kinematics(rot, off, parents, 0, root, pos), Error);
}
