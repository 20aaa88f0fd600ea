// observation.h — the state vector s of a simulated body (humenv-style), read from a MuJoCo mjData.
//
// For B tracked bodies (Humanoid::tracked_bodies(); body 0 = the root), floats, in this order:
//   [0]                      root height z (m)
//   [1, 1 + 3(B-1))          positions of bodies 1..B-1 relative to the root, in the heading frame (m)
//   [.., + 6B)               6D orientation of every body: the first two COLUMNS of its rotation matrix
//                            expressed in the heading frame (R_h = Rz(-yaw) R_body), column-major (c0x c0y c0z c1x...)
//   [.., + 3B)               linear velocity of every body origin, heading frame (m/s)
//   [.., + 3B)               angular velocity of every body, heading frame (rad/s)
// dim = 1 + 3(B-1) + 12B  (B = 21 for our humanoid: 313).
// Heading frame: origin at the root, rotated by the root's yaw, where yaw = atan2 of the root body's x axis
// (its forward direction) projected on the floor. Requires d->xpos, xmat, cvel and subtree_com to be current
// (mj_forward, or mj_kinematics + mj_comPos + mj_comVel). No allocation.
#pragma once
#include <mujoco/mujoco.h>

namespace t2m::sim {

inline constexpr int observation_dim(int num_bodies) { return 1 + 3 * (num_bodies - 1) + 12 * num_bodies; }

// Offsets of the blocks within the observation vector.
struct ObservationLayout {
  int root_height, rel_pos, rot6d, lin_vel, ang_vel, dim;
};
ObservationLayout observation_layout(int num_bodies);

// Writes observation_dim(B) floats to out. Throws t2m::Error on B < 1 or a body id out of range.
void compute_observation(const mjModel* m, const mjData* d, const int* bodies, int B, float* out);

// Yaw (rad) of a rotation matrix (row-major 3x3, MuJoCo xmat): the angle of its x axis projected on the floor.
double heading_yaw(const double* xmat);

}  // namespace t2m::sim
