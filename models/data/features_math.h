// features_math.h — the small rotation helpers the feature code shares (double precision, header-only).
// Quaternions are (w, x, y, z), Hamilton product, column-vector convention (q rotates v as q v q*).
// Rotation matrices are row-major 3x3: m[3 * row + col].
#pragma once
#include <cmath>

namespace t2m::data::fm {

inline constexpr double kPi = 3.14159265358979323846;

// Wraps an angle to (-pi, pi].
inline double wrap_angle(double a) {
  a = std::fmod(a + kPi, 2.0 * kPi);
  if (a < 0) a += 2.0 * kPi;
  return a - kPi;
}

// out = a * b (Hamilton). out may alias neither input.
inline void quat_mul(const double a[4], const double b[4], double out[4]) {
  out[0] = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
  out[1] = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
  out[2] = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
  out[3] = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
}

// Rotation by angle `yaw` (radians) about +Z.
inline void quat_yaw(double yaw, double out[4]) {
  out[0] = std::cos(0.5 * yaw);
  out[1] = 0.0;
  out[2] = 0.0;
  out[3] = std::sin(0.5 * yaw);
}

inline void quat_normalize(double q[4]) {
  double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (n < 1e-12) { q[0] = 1; q[1] = q[2] = q[3] = 0; return; }
  for (int i = 0; i < 4; ++i) q[i] /= n;
}

// Unit quaternion -> rotation matrix (q normalised first).
inline void quat_to_mat(const double qin[4], double m[9]) {
  double q[4] = {qin[0], qin[1], qin[2], qin[3]};
  quat_normalize(q);
  double w = q[0], x = q[1], y = q[2], z = q[3];
  m[0] = 1 - 2 * (y * y + z * z); m[1] = 2 * (x * y - w * z);     m[2] = 2 * (x * z + w * y);
  m[3] = 2 * (x * y + w * z);     m[4] = 1 - 2 * (x * x + z * z); m[5] = 2 * (y * z - w * x);
  m[6] = 2 * (x * z - w * y);     m[7] = 2 * (y * z + w * x);     m[8] = 1 - 2 * (x * x + y * y);
}

// Rotation matrix -> unit quaternion with w >= 0 (Shepperd's method: branch on the largest diagonal term).
inline void mat_to_quat(const double m[9], double q[4]) {
  double tr = m[0] + m[4] + m[8];
  if (tr > 0) {
    double s = std::sqrt(tr + 1.0) * 2;
    q[0] = 0.25 * s; q[1] = (m[7] - m[5]) / s; q[2] = (m[2] - m[6]) / s; q[3] = (m[3] - m[1]) / s;
  } else if (m[0] > m[4] && m[0] > m[8]) {
    double s = std::sqrt(1.0 + m[0] - m[4] - m[8]) * 2;
    q[0] = (m[7] - m[5]) / s; q[1] = 0.25 * s; q[2] = (m[1] + m[3]) / s; q[3] = (m[2] + m[6]) / s;
  } else if (m[4] > m[8]) {
    double s = std::sqrt(1.0 + m[4] - m[0] - m[8]) * 2;
    q[0] = (m[2] - m[6]) / s; q[1] = (m[1] + m[3]) / s; q[2] = 0.25 * s; q[3] = (m[5] + m[7]) / s;
  } else {
    double s = std::sqrt(1.0 + m[8] - m[0] - m[4]) * 2;
    q[0] = (m[3] - m[1]) / s; q[1] = (m[2] + m[6]) / s; q[2] = (m[5] + m[7]) / s; q[3] = 0.25 * s;
  }
  if (q[0] < 0)
    for (int i = 0; i < 4; ++i) q[i] = -q[i];
  quat_normalize(q);
}

// 6D rotation representation (Zhou et al. 2019): the first two columns of R, (R00, R10, R20, R01, R11, R21).
inline void mat_to_6d(const double m[9], double r6[6]) {
  r6[0] = m[0]; r6[1] = m[3]; r6[2] = m[6];
  r6[3] = m[1]; r6[4] = m[4]; r6[5] = m[7];
}

// 6D -> rotation matrix by Gram-Schmidt: c0 = a / |a|, c1 = (b - (c0.b) c0) / |.|, c2 = c0 x c1.
inline void mat_from_6d(const double r6[6], double m[9]) {
  double a[3] = {r6[0], r6[1], r6[2]}, b[3] = {r6[3], r6[4], r6[5]};
  double na = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
  if (na < 1e-12) { a[0] = 1; a[1] = a[2] = 0; na = 1; }
  for (double& v : a) v /= na;
  double d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  for (int i = 0; i < 3; ++i) b[i] -= d * a[i];
  double nb = std::sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
  if (nb < 1e-12) {  // degenerate: any unit vector orthogonal to a
    double t[3] = {std::fabs(a[0]) < 0.9 ? 1.0 : 0.0, std::fabs(a[0]) < 0.9 ? 0.0 : 1.0, 0.0};
    d = a[0] * t[0] + a[1] * t[1] + a[2] * t[2];
    for (int i = 0; i < 3; ++i) b[i] = t[i] - d * a[i];
    nb = std::sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
  }
  for (double& v : b) v /= nb;
  double c[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
  m[0] = a[0]; m[3] = a[1]; m[6] = a[2];
  m[1] = b[0]; m[4] = b[1]; m[7] = b[2];
  m[2] = c[0]; m[5] = c[1]; m[8] = c[2];
}

// Rotates the planar vector (x, y) by angle a about +Z.
inline void rot2(double a, double x, double y, double* ox, double* oy) {
  double c = std::cos(a), s = std::sin(a);
  *ox = c * x - s * y;
  *oy = s * x + c * y;
}

}  // namespace t2m::data::fm
