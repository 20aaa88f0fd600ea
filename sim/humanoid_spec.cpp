// humanoid_spec.cpp — the numbers our humanoid is built from, and the reference pose derived from them.
//
// Provenance (measured once on the Bandai data, every clip of datasets 1 and 2, every 2nd frame):
//   offset_bvh_cm: the BVH OFFSETs (identical in every file, so "mean bone length" = that length);
//   ref_quat_bvh: the mean pose: sign-aligned average of each joint's local quaternion (Hips: of its world
//                 orientation with the heading removed, expressed as BVH-hips-frame -> Z-up world);
//   order: the middle hinge is the twist axis (the world axis closest to the bone in the reference pose);
//   range_deg: 0.05 / 99.95 percentiles of the retargeted hinge angles, widened by 15 degrees, the twist
//              (middle) hinge clamped to ±85 degrees (away from Euler gimbal lock), all clamped to ±170.
//   kp: per joint group, hand-set (legs and trunk stiff, hands and toes soft).
#include <Eigen/Geometry>

#include "sim/humanoid.h"

namespace t2m::sim {

namespace {
// clang-format off
const std::array<HumanoidJointSpec, kHumanoidBodies> kSpec = {{
    {"Hips", -1, {0.00000, 0.00000, 0.00000}, {0.009484, 0.686404, 0.010033, 0.727090}, {0, 2, 1}, {{0, 0}, {0, 0}, {0, 0}}, 0},
    {"Spine", 0, {15.73570, 0.00000, 0.00000}, {0.708301, 0.704090, -0.032120, 0.039170}, {0, 2, 1}, {{-26, 28}, {-24, 25}, {-36, 43}}, 600},
    {"Chest", 1, {8.98455, -0.40621, 0.00000}, {0.999401, -0.006093, 0.009816, 0.032619}, {0, 2, 1}, {{-33, 35}, {-32, 33}, {-32, 45}}, 500},
    {"Neck", 2, {16.37730, 0.00000, 0.00000}, {0.999251, -0.011818, 0.002905, 0.036740}, {0, 2, 1}, {{-30, 29}, {-38, 39}, {-49, 49}}, 150},
    {"Head", 3, {6.45672, 0.00000, 0.00000}, {0.999954, -0.009256, 0.002395, -0.000536}, {0, 2, 1}, {{-40, 42}, {-51, 49}, {-50, 41}}, 80},
    {"Shoulder_L", 2, {12.99420, -0.24272, 4.98039}, {-0.570177, 0.415697, 0.418601, 0.571723}, {0, 1, 2}, {{-28, 38}, {-20, 24}, {-54, 28}}, 200},
    {"UpperArm_L", 5, {5.34809, 0.00000, 0.00000}, {0.860810, -0.060415, -0.221230, -0.454327}, {0, 2, 1}, {{-72, 92}, {-69, 85}, {-109, 111}}, 200},
    {"LowerArm_L", 6, {24.32860, 0.00002, 0.00000}, {0.902287, 0.136586, -0.402807, 0.070484}, {1, 0, 2}, {{-110, 146}, {-71, 53}, {-81, 170}}, 120},
    {"Hand_L", 7, {22.29160, 0.00000, 0.00000}, {0.987496, 0.041065, 0.012861, 0.151659}, {1, 0, 2}, {{-54, 63}, {-40, 71}, {-49, 78}}, 40},
    {"Shoulder_R", 2, {12.99450, -0.24272, -4.98039}, {0.573965, 0.443642, -0.419805, 0.545445}, {0, 1, 2}, {{-45, 30}, {-20, 23}, {-32, 54}}, 200},
    {"UpperArm_R", 9, {-5.34813, 0.00000, 0.00000}, {0.868205, -0.051134, -0.233960, -0.434589}, {0, 2, 1}, {{-79, 64}, {-85, 63}, {-114, 95}}, 200},
    {"LowerArm_R", 10, {-24.32890, 0.00032, 0.00000}, {0.921174, 0.019525, -0.388191, 0.019108}, {1, 0, 2}, {{-101, 145}, {-49, 85}, {-170, 73}}, 120},
    {"Hand_R", 11, {-22.29150, -0.00011, 0.00000}, {0.982017, 0.055917, -0.028165, 0.178111}, {1, 0, 2}, {{-49, 57}, {-58, 68}, {-72, 50}}, 40},
    {"UpperLeg_L", 0, {-2.19248, -6.46944, 0.00000}, {-0.047105, 0.065624, -0.070557, 0.994232}, {0, 2, 1}, {{-35, 46}, {-43, 45}, {-76, 41}}, 700},
    {"LowerLeg_L", 13, {39.08110, 0.00000, -0.00001}, {0.962096, 0.000596, 0.272712, -0.000139}, {0, 2, 1}, {{-22, 20}, {-16, 29}, {-47, 116}}, 600},
    {"Foot_L", 14, {40.98540, 0.00000, -0.00001}, {0.843082, 0.028445, -0.536523, -0.023376}, {0, 2, 1}, {{-42, 39}, {-41, 53}, {-43, 80}}, 1000},
    {"Toes_L", 15, {11.75430, 0.00000, 0.00000}, {0.989318, -0.000661, -0.145772, -0.000077}, {0, 2, 1}, {{-26, 21}, {-17, 20}, {-56, 25}}, 200},
    {"UpperLeg_R", 0, {-2.19251, 6.46944, 0.00000}, {0.117434, 0.991567, -0.013029, -0.053236}, {0, 2, 1}, {{-52, 36}, {-41, 51}, {-78, 38}}, 700},
    {"LowerLeg_R", 17, {-39.08110, -0.00227, -0.04008}, {0.966064, 0.000124, 0.258304, 0.000009}, {0, 2, 1}, {{-22, 28}, {-34, 16}, {-45, 116}}, 600},
    {"Foot_R", 18, {-40.98540, 0.00000, 0.00000}, {0.845420, 0.041870, -0.532413, -0.006898}, {0, 2, 1}, {{-43, 42}, {-58, 42}, {-45, 82}}, 1000},
    {"Toes_R", 19, {-11.75430, 0.00000, 0.00000}, {0.988590, -0.000792, -0.150629, -0.000032}, {0, 2, 1}, {{-21, 20}, {-22, 16}, {-60, 28}}, 200},
}};
// clang-format on

struct Rest {
  std::array<std::array<double, 4>, kHumanoidBodies> rot;
  std::array<std::array<double, 3>, kHumanoidBodies> pos;
};

// BVH basis -> Z-up world basis: (x, y, z)_world = (z, x, y)_bvh, a 120 degree rotation about (1, 1, 1).
Eigen::Quaterniond basis_p() { return Eigen::Quaterniond(0.5, 0.5, 0.5, 0.5); }

Rest compute_rest() {
  Rest r{};
  const Eigen::Quaterniond P = basis_p();
  std::array<Eigen::Quaterniond, kHumanoidBodies> W;
  std::array<Eigen::Vector3d, kHumanoidBodies> pos;
  for (int j = 0; j < kHumanoidBodies; ++j) {
    const auto& s = kSpec[j];
    Eigen::Quaterniond q(s.ref_quat_bvh[0], s.ref_quat_bvh[1], s.ref_quat_bvh[2], s.ref_quat_bvh[3]);
    q.normalize();
    if (s.parent < 0) {
      W[j] = q * P.conjugate();  // BVH hips frame -> world, re-expressed on the Z-up-converted frame
      pos[j].setZero();
    } else {
      const Eigen::Quaterniond local = P * q * P.conjugate();
      const Eigen::Vector3d off = P * Eigen::Vector3d(s.offset_bvh_cm[0], s.offset_bvh_cm[1], s.offset_bvh_cm[2]) / 100.0;
      W[j] = W[s.parent] * local;
      pos[j] = pos[s.parent] + W[s.parent] * off;
    }
    r.rot[j] = {W[j].w(), W[j].x(), W[j].y(), W[j].z()};
    r.pos[j] = {pos[j].x(), pos[j].y(), pos[j].z()};
  }
  return r;
}

const Rest& rest() {
  static const Rest r = compute_rest();
  return r;
}
}  // namespace

const std::array<HumanoidJointSpec, kHumanoidBodies>& humanoid_joint_spec() { return kSpec; }
const std::array<double, 4>& rest_world_rot(int j) { return rest().rot.at(j); }
const std::array<double, 3>& rest_joint_pos(int j) { return rest().pos.at(j); }

}  // namespace t2m::sim
