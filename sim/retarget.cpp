// retarget.cpp — Motion -> qpos (joint rotations to hinge angles), the inverse, and kinematic replay.
#include "sim/retarget.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "sim/atomic_file.h"
#include "sim/observation.h"
#include "tensor/tensor.h"

namespace t2m::sim {

namespace {

using Quat = Eigen::Quaterniond;
using Mat3 = Eigen::Matrix3d;

Quat q_of(const float* q) { return Quat(q[0], q[1], q[2], q[3]).normalized(); }
Quat q_of(const std::array<double, 4>& q) { return Quat(q[0], q[1], q[2], q[3]); }

void require_humanoid(const Humanoid& h, const char* op) {
  if (!h.is_humanoid() || h.root_qpos() < 0)
    throw Error(std::string(op) + ": the model is not the t2m humanoid (needs the 21 named bodies, a free root)");
}

Mat3 axis_rot(int axis, double a) { return Eigen::AngleAxisd(a, Mat3::Identity().col(axis)).toRotationMatrix(); }

}  // namespace

void euler_to_matrix(const int order[3], const double e[3], double R[9]) {
  const Mat3 M = axis_rot(order[0], e[0]) * axis_rot(order[1], e[1]) * axis_rot(order[2], e[2]);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R[3 * r + c] = M(r, c);
}

void matrix_to_euler(const int order[3], const double R[9], double e[3]) {
  // R = R_i(a) R_j(b) R_k(c); s = +1 for cyclic (i, j, k), -1 otherwise.
  const int i = order[0], j = order[1], k = order[2];
  if (i == j || j == k || i == k || i < 0 || j < 0 || k < 0 || i > 2 || j > 2 || k > 2)
    throw Error("matrix_to_euler: order must be a permutation of {0,1,2}");
  const double s = ((j - i + 3) % 3 == 1) ? 1.0 : -1.0;
  auto at = [&](int r, int c) { return R[3 * r + c]; };
  e[1] = std::asin(std::clamp(s * at(i, k), -1.0, 1.0));
  e[0] = std::atan2(-s * at(j, k), at(k, k));
  e[2] = std::atan2(-s * at(i, j), at(i, i));
}

void trajectory_velocities(const Humanoid& h, QposTrajectory& q) {
  const mjModel* m = h.model();
  const int T = q.frames, nq = m->nq, nv = m->nv;
  q.nv = nv;
  q.qvel.assign((size_t)T * nv, 0.0);
  if (T < 2) return;
  const double dt = 1.0 / q.fps;
  for (int t = 0; t < T; ++t) {
    const int a = std::max(0, t - 1), b = std::min(T - 1, t + 1);
    mj_differentiatePos(m, q.qvel.data() + (size_t)t * nv, (b - a) * dt, q.qpos.data() + (size_t)a * nq,
                        q.qpos.data() + (size_t)b * nq);
  }
}

QposTrajectory retarget(const Humanoid& h, const Motion& mo) {
  require_humanoid(h, "retarget");
  validate_motion(mo, "retarget");
  const mjModel* m = h.model();
  const auto& spec = humanoid_joint_spec();
  QposTrajectory q;
  q.frames = mo.frames;
  q.fps = mo.fps;
  q.nq = m->nq;
  q.nv = m->nv;
  q.qpos.assign((size_t)q.frames * m->nq, 0.0);
  std::array<Quat, kNumJoints> Wref_inv;
  for (int j = 0; j < kNumJoints; ++j) Wref_inv[j] = q_of(rest_world_rot(j)).conjugate();
  std::array<Quat, kNumJoints> W, R;
  for (int t = 0; t < q.frames; ++t) {
    double* qp = q.qpos.data() + (size_t)t * m->nq;
    for (int j = 0; j < kNumJoints; ++j) {
      const Quat local = q_of(mo.rot.data() + ((size_t)t * kNumJoints + j) * 4);
      const int p = kJointParents[j];
      W[j] = p < 0 ? local : W[p] * local;
      R[j] = W[j] * Wref_inv[j];
    }
    const int r = h.root_qpos();
    for (int k = 0; k < 3; ++k) qp[r + k] = mo.pos[((size_t)t * kNumJoints) * 3 + k];
    const Quat r0 = R[0].normalized();
    qp[r + 3] = r0.w(), qp[r + 4] = r0.x(), qp[r + 5] = r0.y(), qp[r + 6] = r0.z();
    for (int j = 1; j < kNumJoints; ++j) {
      const Mat3 H = (R[kJointParents[j]].conjugate() * R[j]).toRotationMatrix();
      double Hm[9], e[3];
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) Hm[3 * a + b] = H(a, b);
      matrix_to_euler(spec[j].order, Hm, e);  // the hinge angles of body j
      for (int i = 0; i < 3; ++i) {
        const int k = 3 * (j - 1) + i;
        const double lo = spec[j].range_deg[i][0] * M_PI / 180, hi = spec[j].range_deg[i][1] * M_PI / 180;
        if (e[i] < lo || e[i] > hi) ++q.clamped;
        qp[h.hinge_qpos(k)] = std::clamp(e[i], lo, hi);
      }
    }
  }
  // Feet on the floor: the lowest geom point over the whole clip goes to z = 0.
  mjData* d = mj_makeData(m);
  double lowest = 1e30;
  for (int t = 0; t < q.frames; ++t) {
    mju_copy(d->qpos, q.qpos.data() + (size_t)t * m->nq, m->nq);
    mj_kinematics(m, d);
    for (int g = 0; g < m->ngeom; ++g) {
      if (m->geom_bodyid[g] == 0) continue;
      const double* x = d->geom_xpos + 3 * g;
      const double* X = d->geom_xmat + 9 * g;
      const double* s = m->geom_size + 3 * g;
      double z = x[2];
      if (m->geom_type[g] == mjGEOM_BOX)
        z -= std::abs(X[6]) * s[0] + std::abs(X[7]) * s[1] + std::abs(X[8]) * s[2];
      else if (m->geom_type[g] == mjGEOM_CAPSULE)
        z -= std::abs(X[8]) * s[1] + s[0];
      else
        z -= s[0];
      lowest = std::min(lowest, z);
    }
  }
  mj_deleteData(d);
  q.floor_shift = q.frames > 0 ? -lowest : 0.0;
  for (int t = 0; t < q.frames; ++t) q.qpos[(size_t)t * m->nq + h.root_qpos() + 2] += q.floor_shift;
  trajectory_velocities(h, q);
  return q;
}

Motion motion_from_qpos(const Humanoid& h, const QposTrajectory& q) {
  require_humanoid(h, "motion_from_qpos");
  const mjModel* m = h.model();
  if (q.nq != m->nq || q.qpos.size() != (size_t)q.frames * m->nq || q.frames < 0 || !(q.fps > 0))
    throw Error("motion_from_qpos: trajectory has nq " + std::to_string(q.nq) + ", " + std::to_string(q.qpos.size()) +
                " values for " + std::to_string(q.frames) + " frames, fps " + std::to_string(q.fps) +
                " (model nq " + std::to_string(m->nq) + ")");
  const auto& spec = humanoid_joint_spec();
  Motion mo;
  mo.frames = q.frames;
  mo.fps = q.fps;
  mo.pos.assign((size_t)q.frames * kNumJoints * 3, 0.f);
  mo.rot.assign((size_t)q.frames * kNumJoints * 4, 0.f);
  mo.offsets = humanoid_offsets();
  std::array<Quat, kNumJoints> R, W;
  for (int t = 0; t < q.frames; ++t) {
    const double* qp = q.qpos.data() + (size_t)t * m->nq;
    const int r = h.root_qpos();
    R[0] = Quat(qp[r + 3], qp[r + 4], qp[r + 5], qp[r + 6]).normalized();
    for (int j = 1; j < kNumJoints; ++j) {
      double e[3], Hm[9];
      for (int i = 0; i < 3; ++i) e[i] = qp[h.hinge_qpos(3 * (j - 1) + i)];
      euler_to_matrix(spec[j].order, e, Hm);
      Mat3 H;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) H(a, b) = Hm[3 * a + b];
      R[j] = R[kJointParents[j]] * Quat(H);
    }
    for (int j = 0; j < kNumJoints; ++j) {
      W[j] = R[j] * q_of(rest_world_rot(j));
      const int p = kJointParents[j];
      Quat local = p < 0 ? W[j] : W[p].conjugate() * W[j];
      local.normalize();
      if (local.w() < 0) local.coeffs() *= -1;
      float* o = mo.rot.data() + ((size_t)t * kNumJoints + j) * 4;
      o[0] = float(local.w()), o[1] = float(local.x()), o[2] = float(local.y()), o[3] = float(local.z());
    }
    for (int k = 0; k < 3; ++k) mo.pos[(size_t)t * kNumJoints * 3 + k] = float(qp[r + k]);
  }
  motion_fk(mo);
  return mo;
}

std::vector<float> replay_joint_positions(const Humanoid& h, const QposTrajectory& q) {
  require_humanoid(h, "replay_joint_positions");
  const mjModel* m = h.model();
  if (q.nq != m->nq || q.qpos.size() != (size_t)q.frames * m->nq)
    throw Error("replay_joint_positions: qpos size " + std::to_string(q.qpos.size()) + " != frames * nq");
  std::vector<float> out((size_t)q.frames * kNumJoints * 3);
  mjData* d = mj_makeData(m);
  for (int t = 0; t < q.frames; ++t) {
    mju_copy(d->qpos, q.qpos.data() + (size_t)t * m->nq, m->nq);
    mj_kinematics(m, d);
    for (int j = 0; j < kNumJoints; ++j)
      for (int k = 0; k < 3; ++k)
        out[((size_t)t * kNumJoints + j) * 3 + k] = float(d->xpos[3 * h.tracked_bodies()[j] + k]);
  }
  mj_deleteData(d);
  return out;
}

std::vector<float> replay_observations(const Humanoid& h, const QposTrajectory& q) {
  const mjModel* m = h.model();
  if (q.nq != m->nq || q.nv != m->nv || q.qpos.size() != (size_t)q.frames * m->nq ||
      q.qvel.size() != (size_t)q.frames * m->nv)
    throw Error("replay_observations: trajectory sizes do not match the model (nq " + std::to_string(m->nq) +
                ", nv " + std::to_string(m->nv) + ")");
  const auto& bodies = h.tracked_bodies();
  const int D = observation_dim((int)bodies.size());
  std::vector<float> out((size_t)q.frames * D);
  mjData* d = mj_makeData(m);
  for (int t = 0; t < q.frames; ++t) {
    mju_copy(d->qpos, q.qpos.data() + (size_t)t * m->nq, m->nq);
    mju_copy(d->qvel, q.qvel.data() + (size_t)t * m->nv, m->nv);
    mj_kinematics(m, d);
    mj_comPos(m, d);
    mj_comVel(m, d);
    compute_observation(m, d, bodies.data(), (int)bodies.size(), out.data() + (size_t)t * D);
  }
  mj_deleteData(d);
  return out;
}

ReplayError replay_error(const Humanoid& h, const QposTrajectory& q, const Motion& mo) {
  validate_motion(mo, "replay_error");
  if (mo.frames != q.frames)
    throw Error("replay_error: motion has " + std::to_string(mo.frames) + " frames, trajectory " +
                std::to_string(q.frames));
  const std::vector<float> p = replay_joint_positions(h, q);
  ReplayError e;
  double sum = 0;
  for (int t = 0; t < q.frames; ++t)
    for (int j = 0; j < kNumJoints; ++j) {
      const size_t i = ((size_t)t * kNumJoints + j) * 3;
      const double dx = p[i] - mo.pos[i], dy = p[i + 1] - mo.pos[i + 1], dz = p[i + 2] - (mo.pos[i + 2] + q.floor_shift);
      const double dist = std::sqrt(dx * dx + dy * dy + dz * dz);
      sum += dist;
      e.max_m = std::max(e.max_m, dist);
    }
  e.mean_m = q.frames > 0 ? sum / ((double)q.frames * kNumJoints) : 0.0;
  return e;
}

void save_trajectory_json(const QposTrajectory& q, const std::string& path) {
  if (q.qpos.size() != (size_t)q.frames * q.nq || (!q.qvel.empty() && q.qvel.size() != (size_t)q.frames * q.nv))
    throw Error("save_trajectory_json: sizes do not match frames * nq / nv for '" + path + "'");
  nlohmann::json j = {{"format", "t2m-qpos-1"}, {"fps", q.fps}, {"nq", q.nq},       {"nv", q.nv},
                      {"frames", q.frames},     {"qpos", q.qpos}, {"qvel", q.qvel}};
  write_text_atomic(path, j.dump() + "\n", "save_trajectory_json");
}

QposTrajectory load_trajectory_json(const Humanoid& h, const std::string& path) {
  std::ifstream f(path);
  if (!f) throw Error("load_trajectory_json: cannot open '" + path + "'");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(f);
  } catch (const std::exception& e) {
    throw Error("load_trajectory_json: '" + path + "' is not valid JSON: " + e.what());
  }
  const mjModel* m = h.model();
  QposTrajectory q;
  try {
    if (j.at("format").get<std::string>() != "t2m-qpos-1") throw Error("wrong format tag");
    q.fps = j.at("fps").get<double>();
    q.nq = j.at("nq").get<int>();
    q.nv = j.at("nv").get<int>();
    q.frames = j.at("frames").get<int>();
    q.qpos = j.at("qpos").get<std::vector<double>>();
    if (j.contains("qvel")) q.qvel = j.at("qvel").get<std::vector<double>>();
  } catch (const std::exception& e) {
    throw Error("load_trajectory_json: '" + path + "': bad content (" + e.what() + ")");
  }
  if (q.nq != m->nq || q.nv != m->nv || q.frames < 1 || !(q.fps > 0) || q.qpos.size() != (size_t)q.frames * q.nq ||
      (!q.qvel.empty() && q.qvel.size() != (size_t)q.frames * q.nv))
    throw Error("load_trajectory_json: '" + path + "': " + std::to_string(q.frames) + " frames, nq " +
                std::to_string(q.nq) + ", nv " + std::to_string(q.nv) + ", " + std::to_string(q.qpos.size()) +
                " qpos values, fps " + std::to_string(q.fps) + " (model nq " + std::to_string(m->nq) + ", nv " +
                std::to_string(m->nv) + ")");
  for (double v : q.qpos)
    if (!std::isfinite(v)) throw Error("load_trajectory_json: '" + path + "' has non-finite qpos");
  for (double v : q.qvel)
    if (!std::isfinite(v)) throw Error("load_trajectory_json: '" + path + "' has non-finite qvel");
  if (q.qvel.empty()) trajectory_velocities(h, q);
  return q;
}

}  // namespace t2m::sim
