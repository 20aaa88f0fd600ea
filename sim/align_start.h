// align_start.h — a reference trajectory moved rigidly on the floor so that it starts where a given body stands:
// the rotation about Z and the horizontal shift that put its frame-0 root at the body's root x, y and turn its
// frame-0 heading to the body's. Used to track a clip from the standing start qpos0 (models/bfm/latent_search.h,
// `t2m train bfm-distill --standing-start`): the policy's observation is heading- and position-free, so only the
// world-frame scoring needs the moved reference.
//
//   QposTrajectory moved = align_start(h, clip, h.model()->qpos0);
//
// Per frame (yaw(q) = atan2 of the root's x axis on the floor, as sim/observation.h's heading frame):
//   Δ = yaw(start root) - yaw(qpos[0] root),  root xy' = Rz(Δ) (root xy - root_0 xy) + start xy,  z unchanged,
//   root quat' = quat(Rz(Δ)) ⊗ root quat,  root linear velocity' = Rz(Δ) v (world frame),  hinges and the local
//   angular velocity unchanged.
// Errors (t2m::Error): a trajectory of another model's sizes, no frames.
#pragma once
#include "sim/humanoid.h"
#include "sim/retarget.h"

namespace t2m::sim {

// start: a qpos [nq] of h whose root position and heading the moved trajectory starts at.
QposTrajectory align_start(const Humanoid& h, const QposTrajectory& q, const double* start);

// The heading yaw (rad) of a free-joint quaternion (w, x, y, z): the angle of its x axis projected on the floor.
double root_yaw(const double* quat);

}  // namespace t2m::sim
