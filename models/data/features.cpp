// features.cpp — motion -> HumanML3D-style features (layout in features.h), plus world-frame helpers.
#include "models/data/features.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "models/data/features_math.h"
#include "tensor/tensor.h"

namespace t2m::data {

using namespace fm;
static constexpr int J = kFeatureJoints;
static constexpr int D = kFeatureDim;

void check_motion(const sim::Motion& m, const char* who) {
  if (m.frames < 1) throw Error(std::string(who) + ": motion has " + std::to_string(m.frames) + " frames (need >= 1)");
  if (!(m.fps > 0)) throw Error(std::string(who) + ": fps must be > 0, got " + std::to_string(m.fps));
  size_t T = (size_t)m.frames;
  if (m.pos.size() != T * J * 3)
    throw Error(std::string(who) + ": pos has " + std::to_string(m.pos.size()) + " floats, expected frames*21*3 = " +
                std::to_string(T * J * 3));
  if (m.rot.size() != T * J * 4)
    throw Error(std::string(who) + ": rot has " + std::to_string(m.rot.size()) + " floats, expected frames*21*4 = " +
                std::to_string(T * J * 4));
}

double heading_yaw(const float* p, double fallback) {
  double ax = 0, ay = 0;
  for (auto [l, r] : {std::pair{sim::kUpperLegL, sim::kUpperLegR}, std::pair{sim::kUpperArmL, sim::kUpperArmR}}) {
    ax += (double)p[3 * l + 0] - p[3 * r + 0];
    ay += (double)p[3 * l + 1] - p[3 * r + 1];
  }
  double fx = ay, fy = -ax;  // forward = across x up
  if (std::sqrt(fx * fx + fy * fy) < 1e-6) return fallback;
  return std::atan2(fy, fx);
}

std::vector<float> motion_to_features(const sim::Motion& m, const FeatureConfig& cfg) {
  check_motion(m, "motion_to_features");
  const int T = m.frames;
  const float* P = m.pos.data();
  std::vector<double> yaw(T);
  for (int t = 0; t < T; ++t) yaw[t] = heading_yaw(P + (size_t)t * J * 3, t > 0 ? yaw[t - 1] : 0.0);

  // Lowest height of each contact joint over the clip (the local floor for the contact test).
  double floor_z[4];
  for (int k = 0; k < 4; ++k) {
    floor_z[k] = 1e30;
    for (int t = 0; t < T; ++t) floor_z[k] = std::min(floor_z[k], (double)P[((size_t)t * J + kContactJoints[k]) * 3 + 2]);
  }

  std::vector<float> out((size_t)T * D, 0.0f);
  for (int t = 0; t < T; ++t) {
    float* f = out.data() + (size_t)t * D;
    const float* p = P + (size_t)t * J * 3;
    const double a = yaw[t];
    const double rx = p[0], ry = p[1];
    // Differences with the previous frame (frame 0 uses frame 1 -> 0; T == 1: none).
    const int t1 = t > 0 ? t : (T > 1 ? 1 : -1);
    if (t1 > 0) {
      const float* pc = P + (size_t)t1 * J * 3;
      const float* pp = P + (size_t)(t1 - 1) * J * 3;
      const double at = yaw[t1];
      f[kFeatRootYawVel] = (float)wrap_angle(at - yaw[t1 - 1]);
      double vx, vy;
      rot2(-at, (double)pc[0] - pp[0], (double)pc[1] - pp[1], &vx, &vy);
      f[kFeatRootVel + 0] = (float)vx;
      f[kFeatRootVel + 1] = (float)vy;
      for (int j = 0; j < J; ++j) {
        double dx = (double)pc[3 * j] - pp[3 * j], dy = (double)pc[3 * j + 1] - pp[3 * j + 1];
        double dz = (double)pc[3 * j + 2] - pp[3 * j + 2];
        rot2(-at, dx, dy, &vx, &vy);
        f[kFeatJointVel + 3 * j + 0] = (float)vx;
        f[kFeatJointVel + 3 * j + 1] = (float)vy;
        f[kFeatJointVel + 3 * j + 2] = (float)dz;
      }
      for (int k = 0; k < 4; ++k) {
        const int j = kContactJoints[k];
        double dx = (double)pc[3 * j] - pp[3 * j], dy = (double)pc[3 * j + 1] - pp[3 * j + 1];
        double dz = (double)pc[3 * j + 2] - pp[3 * j + 2];
        double speed = std::sqrt(dx * dx + dy * dy + dz * dz) * m.fps;
        bool low = (double)p[3 * j + 2] - floor_z[k] < cfg.contact_height;
        f[kFeatContact + k] = (low && speed < cfg.contact_speed) ? 1.0f : 0.0f;
      }
    } else {
      for (int k = 0; k < 4; ++k) {  // single frame: contact by height only
        const int j = kContactJoints[k];
        f[kFeatContact + k] = ((double)p[3 * j + 2] - floor_z[k] < cfg.contact_height) ? 1.0f : 0.0f;
      }
    }
    f[kFeatRootHeight] = p[2];
    for (int j = 1; j < J; ++j) {
      double lx, ly;
      rot2(-a, (double)p[3 * j] - rx, (double)p[3 * j + 1] - ry, &lx, &ly);
      f[kFeatLocalPos + 3 * (j - 1) + 0] = (float)lx;
      f[kFeatLocalPos + 3 * (j - 1) + 1] = (float)ly;
      f[kFeatLocalPos + 3 * (j - 1) + 2] = p[3 * j + 2];
    }
    const float* q = m.rot.data() + (size_t)t * J * 4;
    for (int j = 0; j < J; ++j) {
      double qj[4] = {q[4 * j], q[4 * j + 1], q[4 * j + 2], q[4 * j + 3]}, mat[9], r6[6];
      if (j == 0) {
        double qy[4], qr[4];
        quat_yaw(-a, qy);
        quat_mul(qy, qj, qr);
        quat_to_mat(qr, mat);
      } else {
        quat_to_mat(qj, mat);
      }
      mat_to_6d(mat, r6);
      for (int k = 0; k < 6; ++k) f[kFeatRot6d + 6 * j + k] = (float)r6[k];
    }
  }
  return out;
}

void transform_motion(sim::Motion& m, double yaw, double dx, double dy) {
  check_motion(m, "transform_motion");
  double qy[4], q[4], r[4];
  quat_yaw(yaw, qy);
  for (int t = 0; t < m.frames; ++t) {
    float* p = m.pos.data() + (size_t)t * J * 3;
    for (int j = 0; j < J; ++j) {
      double x, y;
      rot2(yaw, p[3 * j], p[3 * j + 1], &x, &y);
      p[3 * j] = (float)(x + dx);
      p[3 * j + 1] = (float)(y + dy);
    }
    float* h = m.rot.data() + (size_t)t * J * 4;
    for (int k = 0; k < 4; ++k) q[k] = h[k];
    quat_mul(qy, q, r);
    for (int k = 0; k < 4; ++k) h[k] = (float)r[k];
  }
}

sim::Motion canonicalize_motion(const sim::Motion& m) {
  check_motion(m, "canonicalize_motion");
  sim::Motion c = m;
  const double yaw0 = heading_yaw(m.pos.data(), 0.0);
  // p' = Rz(-yaw0) (p - root0_xy): rotate the root0-centred motion, no translation afterwards.
  const double r0x = m.pos[0], r0y = m.pos[1];
  for (size_t i = 0; i < c.pos.size(); i += 3) {
    c.pos[i] = (float)((double)m.pos[i] - r0x);
    c.pos[i + 1] = (float)((double)m.pos[i + 1] - r0y);
  }
  transform_motion(c, -yaw0, 0.0, 0.0);
  return c;
}

}  // namespace t2m::data
