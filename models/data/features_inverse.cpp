// features_inverse.cpp — features -> joint positions / rotations (integration of root yaw and planar velocity).
#include <cmath>
#include <string>

#include "models/data/features.h"
#include "models/data/features_math.h"
#include "tensor/tensor.h"

namespace t2m::data {

using namespace fm;
static constexpr int J = kFeatureJoints;
static constexpr int D = kFeatureDim;

namespace {

int feature_frames(const std::vector<float>& f, const char* who) {
  if (f.empty() || f.size() % D != 0)
    throw Error(std::string(who) + ": feature buffer has " + std::to_string(f.size()) +
                " floats, not a positive multiple of " + std::to_string(D));
  return (int)(f.size() / D);
}

// yaw_t and root_t (planar) by integrating the per-frame root velocities; frame 0 is the origin, yaw 0.
void integrate_root(const std::vector<float>& f, int T, std::vector<double>& yaw, std::vector<double>& rx,
                    std::vector<double>& ry) {
  yaw.assign(T, 0.0);
  rx.assign(T, 0.0);
  ry.assign(T, 0.0);
  for (int t = 1; t < T; ++t) {
    const float* r = f.data() + (size_t)t * D;
    yaw[t] = yaw[t - 1] + (double)r[kFeatRootYawVel];
    double dx, dy;
    rot2(yaw[t], r[kFeatRootVel], r[kFeatRootVel + 1], &dx, &dy);
    rx[t] = rx[t - 1] + dx;
    ry[t] = ry[t - 1] + dy;
  }
}

}  // namespace

std::vector<float> features_to_positions(const std::vector<float>& f) {
  const int T = feature_frames(f, "features_to_positions");
  std::vector<double> yaw, rx, ry;
  integrate_root(f, T, yaw, rx, ry);
  std::vector<float> pos((size_t)T * J * 3);
  for (int t = 0; t < T; ++t) {
    const float* r = f.data() + (size_t)t * D;
    float* p = pos.data() + (size_t)t * J * 3;
    p[0] = (float)rx[t];
    p[1] = (float)ry[t];
    p[2] = r[kFeatRootHeight];
    for (int j = 1; j < J; ++j) {
      const float* l = r + kFeatLocalPos + 3 * (j - 1);
      double x, y;
      rot2(yaw[t], l[0], l[1], &x, &y);
      p[3 * j + 0] = (float)(x + rx[t]);
      p[3 * j + 1] = (float)(y + ry[t]);
      p[3 * j + 2] = l[2];
    }
  }
  return pos;
}

std::vector<float> features_to_rotations(const std::vector<float>& f) {
  const int T = feature_frames(f, "features_to_rotations");
  std::vector<double> yaw, rx, ry;
  integrate_root(f, T, yaw, rx, ry);
  std::vector<float> rot((size_t)T * J * 4);
  for (int t = 0; t < T; ++t) {
    const float* r = f.data() + (size_t)t * D;
    for (int j = 0; j < J; ++j) {
      double r6[6], mat[9], q[4];
      for (int k = 0; k < 6; ++k) r6[k] = r[kFeatRot6d + 6 * j + k];
      mat_from_6d(r6, mat);
      mat_to_quat(mat, q);
      if (j == 0) {  // heading frame -> world: R_hips = Rz(yaw_t) R'
        double qy[4], qw[4];
        quat_yaw(yaw[t], qy);
        quat_mul(qy, q, qw);
        if (qw[0] < 0)
          for (double& v : qw) v = -v;
        for (int k = 0; k < 4; ++k) q[k] = qw[k];
      }
      for (int k = 0; k < 4; ++k) rot[((size_t)t * J + j) * 4 + k] = (float)q[k];
    }
  }
  return rot;
}

}  // namespace t2m::data
