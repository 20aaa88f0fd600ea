// position_ik.cpp — bone-direction IK (position_ik.h): Kabsch for branching joints, minimal swing otherwise.
#include "sim/position_ik.h"

#include <Eigen/Dense>
#include <cmath>
#include <string>

#include "sim/skeleton.h"
#include "tensor/tensor.h"

namespace t2m::sim {

namespace {

using Mat3 = Eigen::Matrix3d;
using Vec3 = Eigen::Vector3d;

Vec3 unit_or_zero(const Vec3& v) {
  const double n = v.norm();
  return n > 1e-9 ? Vec3(v / n) : Vec3::Zero();
}

// Smallest rotation taking unit a to unit b (identity when either is zero; a half turn about an axis normal to a
// when they are opposite).
Mat3 min_rotation(const Vec3& a, const Vec3& b) {
  if (a.isZero() || b.isZero()) return Mat3::Identity();
  const double c = std::clamp(a.dot(b), -1.0, 1.0);
  Vec3 axis = a.cross(b);
  double s = axis.norm();
  if (s < 1e-12) {
    if (c > 0) return Mat3::Identity();
    axis = a.unitOrthogonal();
    return Eigen::AngleAxisd(M_PI, axis).toRotationMatrix();
  }
  return Eigen::AngleAxisd(std::atan2(s, c), axis / s).toRotationMatrix();
}

// argmin over rotations W of sum |W o_k - d_k|^2 (Kabsch on the cross-covariance sum d_k o_k^T).
Mat3 kabsch(const Vec3* o, const Vec3* d, int n) {
  Mat3 H = Mat3::Zero();
  for (int k = 0; k < n; ++k) H += d[k] * o[k].transpose();
  Eigen::JacobiSVD<Mat3> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 D = Mat3::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

}  // namespace

std::vector<float> rotations_from_positions(const std::vector<float>& pos, const std::vector<float>& offsets,
                                            const std::vector<float>& ref_world_rot) {
  constexpr int J = kNumJoints;
  if (pos.empty() || pos.size() % (J * 3) != 0 || offsets.size() != (size_t)J * 3)
    throw Error("rotations_from_positions: need pos [T, 21, 3] with T >= 1 and offsets [21, 3], got " +
                std::to_string(pos.size()) + " and " + std::to_string(offsets.size()) + " floats");
  for (size_t i = 0; i < pos.size(); ++i)
    if (!std::isfinite(pos[i]))
      throw Error("rotations_from_positions: non-finite position at frame " + std::to_string(i / (J * 3)));
  if (!ref_world_rot.empty() && ref_world_rot.size() != (size_t)J * 4)
    throw Error("rotations_from_positions: ref_world_rot must be [21, 4], got " +
                std::to_string(ref_world_rot.size()) + " floats");
  const int T = int(pos.size() / (J * 3));
  Mat3 ref_local[J];  // Wref_parent^-1 Wref_j (identity without a reference)
  for (int j = 0; j < J; ++j) ref_local[j] = Mat3::Identity();
  if (!ref_world_rot.empty()) {
    Mat3 Wr[J];
    for (int j = 0; j < J; ++j) {
      const float* q = ref_world_rot.data() + 4 * j;
      Wr[j] = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
    }
    for (int j = 1; j < J; ++j) ref_local[j] = Wr[kJointParents[j]].transpose() * Wr[j];
  }
  std::vector<int> children[J];
  for (int j = 1; j < J; ++j) children[kJointParents[j]].push_back(j);
  Vec3 off[J];
  for (int j = 0; j < J; ++j) off[j] = unit_or_zero(Vec3(offsets[3 * j], offsets[3 * j + 1], offsets[3 * j + 2]));

  std::vector<float> rot((size_t)T * J * 4);
  Mat3 W[J];
  for (int t = 0; t < T; ++t) {
    const float* p = pos.data() + (size_t)t * J * 3;
    auto P = [&](int j) { return Vec3(p[3 * j], p[3 * j + 1], p[3 * j + 2]); };
    for (int j = 0; j < J; ++j) {
      const Mat3 prior = j == 0 ? Mat3::Identity() : Mat3(W[kJointParents[j]] * ref_local[j]);
      const auto& ch = children[j];
      if (ch.size() >= 2) {
        Vec3 o[4], d[4];
        const int n = (int)std::min<size_t>(ch.size(), 4);
        for (int k = 0; k < n; ++k) o[k] = off[ch[k]], d[k] = unit_or_zero(P(ch[k]) - P(j));
        W[j] = kabsch(o, d, n);
      } else if (ch.size() == 1) {
        W[j] = min_rotation(prior * off[ch[0]], unit_or_zero(P(ch[0]) - P(j))) * prior;
      } else {
        W[j] = prior;
      }
      const Mat3 local = j == 0 ? W[0] : Mat3(W[kJointParents[j]].transpose() * W[j]);
      Eigen::Quaterniond q(local);
      q.normalize();
      if (q.w() < 0) q.coeffs() *= -1;
      float* r = rot.data() + ((size_t)t * J + j) * 4;
      r[0] = (float)q.w(), r[1] = (float)q.x(), r[2] = (float)q.y(), r[3] = (float)q.z();
    }
  }
  return rot;
}

}  // namespace t2m::sim
