// test_features_synthetic.h — a walking stick figure for the data tests (header-only, no file I/O).
//
// 21 canonical joints with made-up (slightly asymmetric) bone offsets, a root that walks a curved path at about
// 1.2 m/s starting at an arbitrary world position and heading, legs/arms swinging with the gait phase. pos is
// computed from rot and offsets by the small FK below, so the sim::Motion invariant holds.
#pragma once
#include <cmath>
#include <vector>

#include "sim/skeleton.h"

namespace t2m::testing {

inline void synth_quat_mul(const double a[4], const double b[4], double o[4]) {
  o[0] = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
  o[1] = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
  o[2] = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
  o[3] = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
}
inline void synth_quat_axis(double ax, double ay, double az, double angle, double o[4]) {
  double n = std::sqrt(ax * ax + ay * ay + az * az), s = std::sin(0.5 * angle) / n;
  o[0] = std::cos(0.5 * angle); o[1] = ax * s; o[2] = ay * s; o[3] = az * s;
}
inline void synth_rotate(const double q[4], const double v[3], double o[3]) {
  double p[4] = {0, v[0], v[1], v[2]}, c[4] = {q[0], -q[1], -q[2], -q[3]}, t[4], r[4];
  synth_quat_mul(q, p, t);
  synth_quat_mul(t, c, r);
  o[0] = r[1]; o[1] = r[2]; o[2] = r[3];
}

// FK of the whole motion (the sim::Motion invariant), independent of sim/skeleton.cpp.
inline void synth_fk(sim::Motion& m) {
  for (int t = 0; t < m.frames; ++t) {
    double W[sim::kNumJoints][4];
    for (int j = 0; j < sim::kNumJoints; ++j) {
      const float* q = &m.rot[((size_t)t * 21 + j) * 4];
      double qj[4] = {q[0], q[1], q[2], q[3]};
      int p = sim::kJointParents[j];
      if (p < 0) {
        for (int k = 0; k < 4; ++k) W[j][k] = qj[k];
        continue;
      }
      synth_quat_mul(W[p], qj, W[j]);
      double off[3] = {m.offsets[3 * j], m.offsets[3 * j + 1], m.offsets[3 * j + 2]}, d[3];
      synth_rotate(W[p], off, d);
      for (int k = 0; k < 3; ++k)
        m.pos[((size_t)t * 21 + j) * 3 + k] = (float)(m.pos[((size_t)t * 21 + p) * 3 + k] + d[k]);
    }
  }
}

// frames at 30 fps; yaw0 / x0 / y0: the initial world heading and position; turn: yaw rate (rad/s).
inline sim::Motion synthetic_walk(int frames, double yaw0 = 2.5, double x0 = 3.0, double y0 = -2.0,
                                  double turn = 0.2, double speed = 1.2) {
  sim::Motion m;
  m.frames = frames;
  m.fps = 30.0;
  m.pos.assign((size_t)frames * 21 * 3, 0.0f);
  m.rot.assign((size_t)frames * 21 * 4, 0.0f);
  const float off[21][3] = {
      {0, 0, 0.95f},     {0, 0, 0.10f},     {0, 0, 0.15f},   {0, 0, 0.20f},    {0, 0, 0.10f},
      {0, 0.05f, 0.15f}, {0, 0.12f, 0},     {0, 0, -0.28f},  {0, 0, -0.25f},              // left arm
      {0, -0.05f, 0.15f}, {0, -0.13f, 0},   {0, 0, -0.29f},  {0, 0, -0.26f},              // right arm (longer)
      {0, 0.10f, -0.05f}, {0, 0, -0.42f},   {0, 0, -0.42f},  {0.12f, 0, -0.06f},          // left leg
      {0, -0.10f, -0.05f}, {0, 0, -0.43f},  {0, 0, -0.41f},  {0.13f, 0, -0.06f}};         // right leg
  m.offsets.resize(63);
  for (int j = 0; j < 21; ++j)
    for (int k = 0; k < 3; ++k) m.offsets[3 * j + k] = off[j][k];
  double yaw = yaw0, x = x0, y = y0;
  for (int t = 0; t < frames; ++t) {
    const double ts = t / 30.0, phase = 2 * M_PI * 0.9 * ts;
    if (t > 0) {
      yaw += (turn + 0.3 * std::cos(0.5 * ts)) / 30.0;
      x += speed / 30.0 * std::cos(yaw);
      y += speed / 30.0 * std::sin(yaw);
    }
    float* p = &m.pos[(size_t)t * 63];
    p[0] = (float)x; p[1] = (float)y; p[2] = (float)(0.95 + 0.02 * std::sin(2 * phase));
    auto set = [&](int j, const double q[4]) {
      for (int k = 0; k < 4; ++k) m.rot[((size_t)t * 21 + j) * 4 + k] = (float)q[k];
    };
    double qy[4], qr[4], qh[4], q[4];
    synth_quat_axis(0, 0, 1, yaw, qy);
    synth_quat_axis(1, 0, 0, 0.05 * std::sin(phase), qr);
    synth_quat_mul(qy, qr, qh);
    set(0, qh);
    for (int j = 1; j < 21; ++j) {
      double a = 0, ax = 0, ay = 1, az = 0;
      switch (j) {
        case sim::kSpine: a = 0.1 * std::sin(phase); ax = 0; ay = 0; az = 1; break;
        case sim::kUpperArmL: a = -0.4 * std::sin(phase); break;
        case sim::kUpperArmR: a = 0.4 * std::sin(phase); break;
        case sim::kLowerArmL: case sim::kLowerArmR: a = -0.3; break;
        case sim::kUpperLegL: a = 0.45 * std::sin(phase); break;
        case sim::kUpperLegR: a = -0.45 * std::sin(phase); break;
        case sim::kLowerLegL: a = 0.5 * std::max(0.0, std::cos(phase)); break;
        case sim::kLowerLegR: a = 0.5 * std::max(0.0, -std::cos(phase)); break;
        case sim::kHead: a = 0.1 * std::sin(0.3 * phase); ax = 1; ay = 0; break;
        default: a = 0.02 * j; ax = 1; ay = 1; az = 0; break;
      }
      synth_quat_axis(ax, ay, az, a, q);
      set(j, q);
    }
  }
  synth_fk(m);
  return m;
}

// A figure standing still (rest pose, yaw `yaw`) for `frames` frames.
inline sim::Motion synthetic_stand(int frames, double yaw = 0.0) {
  sim::Motion m = synthetic_walk(frames, yaw, 0.0, 0.0, 0.0, 0.0);
  for (int t = 0; t < frames; ++t)
    for (int j = 0; j < 21; ++j) {
      float* q = &m.rot[((size_t)t * 21 + j) * 4];
      double qy[4];
      synth_quat_axis(0, 0, 1, j == 0 ? yaw : 0.0, qy);
      for (int k = 0; k < 4; ++k) q[k] = (float)qy[k];
    }
  for (int t = 0; t < frames; ++t) m.pos[(size_t)t * 63 + 2] = 0.95f;
  synth_fk(m);
  return m;
}

}  // namespace t2m::testing
