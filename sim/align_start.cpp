// align_start.cpp — the rigid floor move of align_start.h, frame by frame on the free joint.
#include "sim/align_start.h"

#include <cmath>
#include <string>

#include "tensor/tensor.h"

namespace t2m::sim {

double root_yaw(const double* q) {
  // x axis of R(q): (1 - 2(y² + z²), 2(xy + wz), 2(xz - wy)); its floor angle.
  return std::atan2(2.0 * (q[1] * q[2] + q[0] * q[3]), 1.0 - 2.0 * (q[2] * q[2] + q[3] * q[3]));
}

QposTrajectory align_start(const Humanoid& h, const QposTrajectory& q, const double* start) {
  const int nq = h.model()->nq, nv = h.model()->nv;
  if (q.frames < 1 || q.nq != nq || q.nv != nv || q.qpos.size() != (size_t)q.frames * nq ||
      q.qvel.size() != (size_t)q.frames * nv)
    throw Error("align_start: a trajectory of " + std::to_string(q.frames) + " frames, nq " + std::to_string(q.nq) +
                ", nv " + std::to_string(q.nv) + " for a model of nq " + std::to_string(nq) + ", nv " +
                std::to_string(nv));
  const double delta = root_yaw(start + 3) - root_yaw(q.qpos.data() + 3);
  const double c = std::cos(delta), s = std::sin(delta);
  const double ch = std::cos(delta / 2), sh = std::sin(delta / 2);  // quat(Rz(Δ)) = (ch, 0, 0, sh)
  const double x0 = q.qpos[0], y0 = q.qpos[1];
  QposTrajectory out = q;
  for (int t = 0; t < q.frames; ++t) {
    double* p = out.qpos.data() + (size_t)t * nq;
    const double dx = p[0] - x0, dy = p[1] - y0;
    p[0] = c * dx - s * dy + start[0];
    p[1] = s * dx + c * dy + start[1];
    const double w = p[3], x = p[4], y = p[5], z = p[6];  // (ch, 0, 0, sh) ⊗ (w, x, y, z)
    p[3] = ch * w - sh * z;
    p[4] = ch * x - sh * y;
    p[5] = ch * y + sh * x;
    p[6] = ch * z + sh * w;
    double* v = out.qvel.data() + (size_t)t * nv;
    const double vx = v[0], vy = v[1];
    v[0] = c * vx - s * vy;
    v[1] = s * vx + c * vy;
  }
  return out;
}

}  // namespace t2m::sim
