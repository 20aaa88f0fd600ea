// observation.cpp — heading-frame body state from mjData (see observation.h for the layout).
#include "sim/observation.h"

#include <cmath>
#include <string>

#include "tensor/tensor.h"

namespace t2m::sim {

ObservationLayout observation_layout(int B) {
  ObservationLayout l{};
  l.root_height = 0;
  l.rel_pos = 1;
  l.rot6d = l.rel_pos + 3 * (B - 1);
  l.lin_vel = l.rot6d + 6 * B;
  l.ang_vel = l.lin_vel + 3 * B;
  l.dim = l.ang_vel + 3 * B;
  return l;
}

double heading_yaw(const double* xmat) { return std::atan2(xmat[3], xmat[0]); }

void compute_observation(const mjModel* m, const mjData* d, const int* bodies, int B, float* out) {
  if (B < 1) throw Error("compute_observation: need at least one body (got " + std::to_string(B) + ")");
  for (int i = 0; i < B; ++i)
    if (bodies[i] <= 0 || bodies[i] >= m->nbody)
      throw Error("compute_observation: body id " + std::to_string(bodies[i]) + " out of range [1, " +
                  std::to_string(m->nbody) + ")");
  const ObservationLayout L = observation_layout(B);
  const int r = bodies[0];
  const double* rp = d->xpos + 3 * r;
  const double yaw = heading_yaw(d->xmat + 9 * r);
  const double c = std::cos(yaw), s = std::sin(yaw);
  // Rz(-yaw) applied to a world vector v: (c vx + s vy, -s vx + c vy, vz)
  auto to_heading = [&](const double* v, float* o) {
    o[0] = float(c * v[0] + s * v[1]);
    o[1] = float(-s * v[0] + c * v[1]);
    o[2] = float(v[2]);
  };
  out[L.root_height] = float(rp[2]);
  for (int i = 1; i < B; ++i) {
    const double* p = d->xpos + 3 * bodies[i];
    const double rel[3] = {p[0] - rp[0], p[1] - rp[1], p[2] - rp[2]};
    to_heading(rel, out + L.rel_pos + 3 * (i - 1));
  }
  for (int i = 0; i < B; ++i) {
    const int b = bodies[i];
    const double* R = d->xmat + 9 * b;
    const double c0[3] = {R[0], R[3], R[6]}, c1[3] = {R[1], R[4], R[7]};
    to_heading(c0, out + L.rot6d + 6 * i);
    to_heading(c1, out + L.rot6d + 6 * i + 3);
    // cvel = [angular; linear] at subtree_com of the body's root (MuJoCo convention, world orientation).
    const double* cv = d->cvel + 6 * b;
    const double* com = d->subtree_com + 3 * m->body_rootid[b];
    const double* p = d->xpos + 3 * b;
    const double off[3] = {p[0] - com[0], p[1] - com[1], p[2] - com[2]};
    const double v[3] = {cv[3] + cv[1] * off[2] - cv[2] * off[1], cv[4] + cv[2] * off[0] - cv[0] * off[2],
                         cv[5] + cv[0] * off[1] - cv[1] * off[0]};
    to_heading(v, out + L.lin_vel + 3 * i);
    to_heading(cv, out + L.ang_vel + 3 * i);
  }
}

}  // namespace t2m::sim
