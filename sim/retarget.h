// retarget.h — canonical Motion (sim/skeleton.h) <-> humanoid qpos trajectories, and kinematic replay.
//
// Forward (data -> robot), per frame t and body j (Motion basis, Z up):
//   W_j = W_parent rot[t, j] (W_0 = rot[t, 0])          world rotation of the data joint frame
//   R_j = W_j Wref_j^-1                                   world rotation of humanoid body j (Wref: rest_world_rot)
//   root qpos = (pos[t, 0] + (0, 0, floor_shift), quat(R_0));   hinge angles of body j: the Euler angles of
//   H_j = R_parent^-1 R_j in the body's hinge order (R = R_a(q0) R_b(q1) R_c(q2)), each clamped to its range.
// Because the bodies are built from the data's own bone offsets, replay reproduces the data exactly except where
// a joint limit clamps. floor_shift: one constant per clip so the lowest sole point over the clip touches z = 0
// (feet on the floor, vertical motion kept). qvel: central differences of qpos (mj_differentiatePos), one-sided at
// the ends; the free-joint angular velocity is in the root's local frame (MuJoCo convention).
// Inverse (robot -> data, used by export): rot[t, j] = W_parent^-1 W_j with W_j = R_j Wref_j, offsets = the
// humanoid's bone offsets, pos by sim FK. motion_from_qpos(retarget(m)) == m up to clamping and floor_shift.
// Errors: a Motion failing validate_motion, a model that is not our humanoid, wrong qpos sizes -> t2m::Error.
#pragma once
#include <string>
#include <vector>

#include "sim/humanoid.h"
#include "sim/skeleton.h"

namespace t2m::sim {

struct QposTrajectory {
  int frames = 0;
  double fps = kCanonicalFps;
  int nq = 0, nv = 0;
  std::vector<double> qpos;  // [frames, nq]
  std::vector<double> qvel;  // [frames, nv]
  int clamped = 0;           // hinge values clamped to their range (retarget only)
  double floor_shift = 0;    // metres added to the root height (retarget only)
};

QposTrajectory retarget(const Humanoid& h, const Motion& m);
// Recomputes qvel from qpos by finite differences (central inside, one-sided at the ends).
void trajectory_velocities(const Humanoid& h, QposTrajectory& q);
Motion motion_from_qpos(const Humanoid& h, const QposTrajectory& q);

// Kinematic replay (mj_kinematics per frame): body origins = the 21 joint positions, [frames, 21, 3] metres.
std::vector<float> replay_joint_positions(const Humanoid& h, const QposTrajectory& q);
// The state sequence s_1..T of a trajectory (mj_forward with qpos, qvel per frame): [frames, observation dim].
std::vector<float> replay_observations(const Humanoid& h, const QposTrajectory& q);

struct ReplayError {
  double mean_m = 0;  // mean over frames and joints of |replay - data| (data shifted by floor_shift)
  double max_m = 0;
};
ReplayError replay_error(const Humanoid& h, const QposTrajectory& q, const Motion& m);

// A state sequence on disk (JSON): {"format": "t2m-qpos-1", "fps": 30, "nq": 67, "nv": 66, "frames": T,
// "qpos": [T*nq numbers], "qvel": [T*nv numbers]} (qvel may be absent: then recomputed by finite differences when
// loaded for a humanoid). save writes PATH.tmp then renames. load throws t2m::Error on a missing file, bad JSON,
// wrong format tag, sizes that do not match, non-finite values, or nq/nv different from the model's.
void save_trajectory_json(const QposTrajectory& q, const std::string& path);
QposTrajectory load_trajectory_json(const Humanoid& h, const std::string& path);

// Euler helpers (exposed for tests): R (row-major 3x3) = R_a(e0) R_b(e1) R_c(e2) for axes order {a, b, c}, a
// permutation of {0, 1, 2}; decompose returns e1 in [-pi/2, pi/2].
void euler_to_matrix(const int order[3], const double e[3], double R[9]);
void matrix_to_euler(const int order[3], const double R[9], double e[3]);

}  // namespace t2m::sim
