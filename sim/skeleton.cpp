// skeleton.cpp — canonical skeleton tables, BVH <-> Motion conversion, forward kinematics (quaternions, double).
#include "sim/skeleton.h"

#include <cmath>

#include "tensor/tensor.h"

namespace t2m::sim {

const std::array<const char*, kNumJoints> kJointNames = {
    "Hips",       "Spine",      "Chest",      "Neck",       "Head",       "Shoulder_L", "UpperArm_L",
    "LowerArm_L", "Hand_L",     "Shoulder_R", "UpperArm_R", "LowerArm_R", "Hand_R",     "UpperLeg_L",
    "LowerLeg_L", "Foot_L",     "Toes_L",     "UpperLeg_R", "LowerLeg_R", "Foot_R",     "Toes_R"};
const std::array<int, kNumJoints> kJointParents = {-1, 0, 1, 2, 3, 2, 5, 6, 7, 2, 9, 10, 11, 0, 13, 14, 15, 0, 17, 18, 19};
const std::array<int, kNumJoints> kJointMirror = {0,  1,  2,  3,  4,  9,  10, 11, 12, 5,  6,
                                                  7,  8,  17, 18, 19, 20, 13, 14, 15, 16};

int joint_index(const std::string& name) {
  for (int j = 0; j < kNumJoints; ++j)
    if (name == kJointNames[j]) return j;
  return -1;
}

namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

// Hamilton product a*b of (w,x,y,z) quaternions.
inline void qmul(const double a[4], const double b[4], double o[4]) {
  const double w = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
  const double x = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
  const double y = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
  const double z = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
  o[0] = w, o[1] = x, o[2] = y, o[3] = z;
}

// v' = q v q^* for a unit quaternion q.
inline void qrot(const double q[4], const double v[3], double o[3]) {
  // t = 2 (q.xyz x v); v' = v + w t + q.xyz x t
  const double tx = 2 * (q[2] * v[2] - q[3] * v[1]);
  const double ty = 2 * (q[3] * v[0] - q[1] * v[2]);
  const double tz = 2 * (q[1] * v[1] - q[2] * v[0]);
  o[0] = v[0] + q[0] * tx + (q[2] * tz - q[3] * ty);
  o[1] = v[1] + q[0] * ty + (q[3] * tx - q[1] * tz);
  o[2] = v[2] + q[0] * tz + (q[1] * ty - q[2] * tx);
}

inline void qnormalize(double q[4]) {
  const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (n > 0 && std::isfinite(n)) {
    for (int k = 0; k < 4; ++k) q[k] /= n;
  } else {
    q[0] = 1, q[1] = q[2] = q[3] = 0;
  }
}

}  // namespace

void bvh_to_world_vec(const double in[3], double out[3]) {
  const double x = in[0], y = in[1], z = in[2];
  out[0] = z / 100.0, out[1] = x / 100.0, out[2] = y / 100.0;
}
void world_to_bvh_vec(const double in[3], double out[3]) {
  const double x = in[0], y = in[1], z = in[2];
  out[0] = y * 100.0, out[1] = z * 100.0, out[2] = x * 100.0;
}
void bvh_to_world_quat(const double in[4], double out[4]) {
  const double w = in[0], x = in[1], y = in[2], z = in[3];
  out[0] = w, out[1] = z, out[2] = x, out[3] = y;
}
void world_to_bvh_quat(const double in[4], double out[4]) {
  const double w = in[0], x = in[1], y = in[2], z = in[3];
  out[0] = w, out[1] = y, out[2] = z, out[3] = x;
}

void quat_from_euler_deg(const Channel* order, const double* deg, int n, double out[4]) {
  double q[4] = {1, 0, 0, 0};
  for (int k = 0; k < n; ++k) {
    if (!is_rotation(order[k]))
      throw Error(std::string("quat_from_euler_deg: ") + channel_name(order[k]) + " is not a rotation channel");
    const double h = 0.5 * deg[k] * kDegToRad;
    double e[4] = {std::cos(h), 0, 0, 0};
    e[1 + channel_axis(order[k])] = std::sin(h);
    double r[4];
    qmul(q, e, r);
    for (int i = 0; i < 4; ++i) q[i] = r[i];
  }
  for (int i = 0; i < 4; ++i) out[i] = q[i];
}

void quat_to_euler_zxy_deg(const double qin[4], double out[3]) {
  double q[4] = {qin[0], qin[1], qin[2], qin[3]};
  qnormalize(q);
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  // Rotation matrix entries of R = Rz(a) Rx(b) Ry(c): R21 = sin b, R01 = -sin a cos b, R11 = cos a cos b,
  // R20 = -cos b sin c, R22 = cos b cos c.
  const double r00 = 1 - 2 * (y * y + z * z), r01 = 2 * (x * y - w * z);
  const double r10 = 2 * (x * y + w * z), r11 = 1 - 2 * (x * x + z * z);
  const double r20 = 2 * (x * z - w * y), r21 = 2 * (y * z + w * x), r22 = 1 - 2 * (x * x + y * y);
  const double sb = std::fmax(-1.0, std::fmin(1.0, r21));
  double a, b = std::asin(sb), c;
  if (std::fabs(sb) < 1 - 1e-12) {
    a = std::atan2(-r01, r11);
    c = std::atan2(-r20, r22);
  } else {  // gimbal lock: cos b = 0, only a + c (or a - c) is defined; put it all in a
    a = std::atan2(r10, r00);
    c = 0;
  }
  out[0] = a / kDegToRad, out[1] = b / kDegToRad, out[2] = c / kDegToRad;
}

void forward_kinematics(const float* rot, const float* offsets, const int* parents, int J, const float* root_pos,
                        float* pos_out, float* world_rot_out) {
  if (J <= 0 || J > kBvhMaxJoints) throw Error("forward_kinematics: joint count " + std::to_string(J));
  // Small fixed scratch on the stack for the canonical size; heap only for large skeletons.
  double stack_buf[64 * 7];
  std::vector<double> heap;
  double* W = stack_buf;  // [J, 4] world rotations then [J, 3] positions
  if (J > 64) heap.resize((size_t)J * 7), W = heap.data();
  double* P = W + (size_t)J * 4;
  for (int j = 0; j < J; ++j) {
    const int p = parents[j];
    if (j == 0 ? p != -1 : (p < 0 || p >= j))
      throw Error("forward_kinematics: joint " + std::to_string(j) + " has parent " + std::to_string(p) +
                  " (need -1 for joint 0, else 0 <= parent < joint)");
    double q[4] = {rot[4 * j], rot[4 * j + 1], rot[4 * j + 2], rot[4 * j + 3]};
    qnormalize(q);
    if (j == 0) {
      for (int k = 0; k < 4; ++k) W[k] = q[k];
      for (int k = 0; k < 3; ++k) P[k] = root_pos[k];
    } else {
      qmul(W + 4 * p, q, W + 4 * j);                      // W_j = W_parent rot_j
      const double o[3] = {offsets[3 * j], offsets[3 * j + 1], offsets[3 * j + 2]};
      double r[3];
      qrot(W + 4 * p, o, r);                              // pos_j = pos_parent + W_parent offset_j
      for (int k = 0; k < 3; ++k) P[3 * j + k] = P[3 * p + k] + r[k];
    }
  }
  for (int i = 0; i < 3 * J; ++i) pos_out[i] = (float)P[i];
  if (world_rot_out)
    for (int i = 0; i < 4 * J; ++i) world_rot_out[i] = (float)W[i];
}

void validate_motion(const Motion& m, const std::string& what) {
  const size_t T = m.frames < 0 ? 0 : (size_t)m.frames;
  if (m.frames < 0 || m.pos.size() != T * kNumJoints * 3 || m.rot.size() != T * kNumJoints * 4 ||
      m.offsets.size() != (size_t)kNumJoints * 3)
    throw Error(what + ": bad Motion sizes: frames " + std::to_string(m.frames) + ", pos " +
                std::to_string(m.pos.size()) + " (want T*63), rot " + std::to_string(m.rot.size()) +
                " (want T*84), offsets " + std::to_string(m.offsets.size()) + " (want 63)");
  if (!(m.fps > 0) || !std::isfinite(m.fps)) throw Error(what + ": bad fps " + std::to_string(m.fps));
  for (const auto* v : {&m.pos, &m.rot, &m.offsets})
    for (float x : *v)
      if (!std::isfinite(x)) throw Error(what + ": non-finite value in Motion");
}

void motion_fk(Motion& m) {
  validate_motion(m, "motion_fk");
  for (int t = 0; t < m.frames; ++t) {
    float* pos = m.pos.data() + (size_t)t * kNumJoints * 3;
    const float root[3] = {pos[0], pos[1], pos[2]};
    forward_kinematics(m.rot.data() + (size_t)t * kNumJoints * 4, m.offsets.data(), kJointParents.data(),
                       kNumJoints, root, pos);
  }
}

Motion motion_from_bvh(const BvhMotion& bvh) {
  const int NJ = (int)bvh.joints.size();
  const int C = bvh.total_channels();
  if (bvh.frames < 0 || bvh.values.size() != (size_t)bvh.frames * C)
    throw Error("motion_from_bvh: values has " + std::to_string(bvh.values.size()) + " entries, expected " +
                std::to_string(bvh.frames) + " x " + std::to_string(C));
  if (!(bvh.frame_time > 0)) throw Error("motion_from_bvh: bad frame_time " + std::to_string(bvh.frame_time));
  int idx[kNumJoints];
  std::string missing;
  for (int j = 0; j < kNumJoints; ++j) {
    idx[j] = bvh.find_joint(kJointNames[j]);
    if (idx[j] < 0) missing += std::string(missing.empty() ? "" : ", ") + kJointNames[j];
  }
  if (!missing.empty()) throw Error("motion_from_bvh: the BVH lacks canonical joints: " + missing);
  for (int j = 1; j < kNumJoints; ++j)
    if (bvh.joints[idx[j]].parent != idx[kJointParents[j]])
      throw Error(std::string("motion_from_bvh: joint ") + kJointNames[j] + " must be a child of " +
                  kJointNames[kJointParents[j]] + " in the BVH");
  // The chain from the BVH root down to Hips (folded into the Hips world transform).
  std::vector<int> chain;
  for (int a = idx[kHips]; a >= 0; a = bvh.joints[a].parent) chain.insert(chain.begin(), a);
  // Per BVH joint: first channel column, rotation channel order / columns, position columns.
  std::vector<int> col(NJ);
  for (int j = 0, c = 0; j < NJ; ++j) col[j] = c, c += (int)bvh.joints[j].channels.size();
  auto local = [&](int j, const double* row, double q[4], double tr[3]) {
    const BvhJoint& J = bvh.joints[j];
    Channel order[6];
    double deg[6];
    int n = 0;
    for (int k = 0; k < 3; ++k) tr[k] = J.offset[k];
    for (size_t c = 0; c < J.channels.size(); ++c) {
      const double v = row[col[j] + c];
      if (is_rotation(J.channels[c])) {
        order[n] = J.channels[c], deg[n++] = v;
      } else {
        tr[channel_axis(J.channels[c])] = v;  // position channel replaces the OFFSET component
      }
    }
    quat_from_euler_deg(order, deg, n, q);
  };

  Motion m;
  m.frames = bvh.frames;
  m.fps = 1.0 / bvh.frame_time;
  m.pos.resize((size_t)m.frames * kNumJoints * 3);
  m.rot.resize((size_t)m.frames * kNumJoints * 4);
  m.offsets.resize(kNumJoints * 3);
  for (int j = 0; j < kNumJoints; ++j) {
    double o[3];
    bvh_to_world_vec(bvh.joints[idx[j]].offset, o);
    for (int k = 0; k < 3; ++k) m.offsets[3 * j + k] = (float)o[k];
  }
  for (int t = 0; t < m.frames; ++t) {
    const double* row = bvh.frame(t);
    float* rot = m.rot.data() + (size_t)t * kNumJoints * 4;
    // Hips world transform in BVH coordinates: compose the chain root -> ... -> Hips.
    double W[4] = {1, 0, 0, 0}, P[3] = {0, 0, 0};
    for (int a : chain) {
      double q[4], tr[3], r[3], Wn[4];
      local(a, row, q, tr);
      qrot(W, tr, r);
      for (int k = 0; k < 3; ++k) P[k] += r[k];
      qmul(W, q, Wn);
      for (int k = 0; k < 4; ++k) W[k] = Wn[k];
    }
    double qw[4], pw[3];
    bvh_to_world_quat(W, qw);
    bvh_to_world_vec(P, pw);
    for (int k = 0; k < 4; ++k) rot[k] = (float)qw[k];
    for (int j = 1; j < kNumJoints; ++j) {
      double q[4], tr[3];
      local(idx[j], row, q, tr);
      bvh_to_world_quat(q, qw);
      for (int k = 0; k < 4; ++k) rot[4 * j + k] = (float)qw[k];
    }
    const float root[3] = {(float)pw[0], (float)pw[1], (float)pw[2]};
    forward_kinematics(rot, m.offsets.data(), kJointParents.data(), kNumJoints, root,
                       m.pos.data() + (size_t)t * kNumJoints * 3);
  }
  return m;
}

BvhMotion bvh_from_motion(const Motion& m) {
  validate_motion(m, "bvh_from_motion");
  const Channel kLayout[6] = {Channel::Xposition, Channel::Yposition, Channel::Zposition,
                              Channel::Zrotation, Channel::Xrotation, Channel::Yrotation};
  BvhMotion b;
  b.frames = m.frames;
  b.frame_time = 1.0 / m.fps;
  b.joints.resize(kNumJoints + 1);
  b.joints[0].name = "joint_Root";
  b.joints[0].parent = -1;
  for (int j = 0; j < kNumJoints; ++j) {
    BvhJoint& J = b.joints[j + 1];
    J.name = kJointNames[j];
    J.parent = kJointParents[j] + 1;  // joint_Root is BVH joint 0, Hips is 1
    const double o[3] = {m.offsets[3 * j], m.offsets[3 * j + 1], m.offsets[3 * j + 2]};
    world_to_bvh_vec(o, J.offset);
    J.has_end_site = (j == kHead || j == kHandL || j == kHandR || j == kToesL || j == kToesR);
  }
  for (auto& J : b.joints) J.channels.assign(kLayout, kLayout + 6);
  const int C = 6 * (kNumJoints + 1);
  b.values.assign((size_t)m.frames * C, 0.0);
  for (int t = 0; t < m.frames; ++t) {
    double* row = b.frame(t);
    const float* rot = m.rot.data() + (size_t)t * kNumJoints * 4;
    const float* pos = m.pos.data() + (size_t)t * kNumJoints * 3;
    for (int j = 0; j < kNumJoints; ++j) {
      double* r = row + 6 * (j + 1);
      if (j == 0) {
        const double p[3] = {pos[0], pos[1], pos[2]};
        world_to_bvh_vec(p, r);
      } else {
        for (int k = 0; k < 3; ++k) r[k] = b.joints[j + 1].offset[k];
      }
      const double q[4] = {rot[4 * j], rot[4 * j + 1], rot[4 * j + 2], rot[4 * j + 3]};
      double qb[4];
      world_to_bvh_quat(q, qb);
      quat_to_euler_zxy_deg(qb, r + 3);
    }
  }
  return b;
}

}  // namespace t2m::sim
