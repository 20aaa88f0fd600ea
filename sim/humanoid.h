// humanoid.h — our MuJoCo humanoid: the MJCF is generated in C++ from the Bandai skeleton (bone lengths, a
// reference pose, data-derived joint limits), and a read-only wrapper around the compiled mjModel.
//
// Topology: 21 bodies named after the canonical joints of sim/skeleton.h (same indices). Hips carries a free
// joint; every other body has 3 hinges (ball-like), named "<Joint>_x", "<Joint>_y", "<Joint>_z" after their axis,
// listed in the joint's Euler order (middle hinge = the twist axis along the bone; see humanoid_joint_spec()).
// 60 hinges, 60 position actuators (one per hinge, same order), nq = 67, nv = 66, nu = 60.
//
// Frames: Z up, X forward, Y left (metres, radians, kg). At qpos0 (free joint at the origin/identity, all hinges 0)
// every body frame is aligned with the world and the body stands in the reference pose: the mean pose of the
// Bandai data (knees and elbows slightly bent), hips kHumanoidHipsHeight above the floor.
// The Bandai joint frame j relates to body frame j by a constant rotation: R_body_j = W_j * Wref_j^-1, where W_j
// is the world rotation of joint j in the canonical Motion (sim/skeleton.h) and Wref_j = rest_world_rot(j).
//
// Physics: dt = 1/450 s, 15 substeps per 30 Hz control step, Euler integrator (joint damping is implicit there),
// elliptic friction cones (true Coulomb cones, 3 constraint rows per contact instead of the pyramid's 4), PGS solver,
// 6 iterations (docs/SIM.md §8: 16 % fewer instructions per control step than pyramidal PGS 10, 0.20 mm mean and
// 0.66 mm largest one-step deviation from a converged Newton solution of the same model). Contacts: only body–floor, listed as explicit <pair>s with collision="predefined" (no broadphase;
// the same contacts as geoms with contype 1 / conaffinity 0 against a 1 / 1 floor, which the geoms also carry),
// no self collision (self_collision = true: dynamic contacts between all geoms instead); feet and toes are boxes
// with flat soles. Position actuators: ctrlrange = the hinge range,
// force = kp (ctrl - q), plus joint damping kd = kp / 10 (the D term); forcerange = ±kp * 1 rad.
// Masses from geom volumes at density 1000 kg/m^3 (58.6 kg in total, see model_total_mass()).
#pragma once
#include <mujoco/mujoco.h>

#include <array>
#include <memory>
#include <string>
#include <vector>

namespace t2m::sim {

inline constexpr int kHumanoidBodies = 21;      // = kNumJoints of sim/skeleton.h
inline constexpr int kHumanoidHinges = 60;      // 3 per non-root body
inline constexpr double kPhysicsDt = 1.0 / 450.0;
inline constexpr int kSubsteps = 15;            // physics steps per control step
inline constexpr double kControlDt = kPhysicsDt * kSubsteps;  // 1/30 s

// One body joint of the humanoid, as stored (Bandai BVH basis: cm, Y up; the code converts to Z up).
struct HumanoidJointSpec {
  const char* name;
  int parent;                  // index, -1 for Hips
  double offset_bvh_cm[3];     // bone offset from the parent in the parent's BVH frame
  double ref_quat_bvh[4];      // reference-pose rotation (w,x,y,z) in the BVH basis: local for j > 0; for Hips the
                               // map from the BVH hips frame to the Z-up world (heading removed)
  int order[3];                // hinge axes (0 = x, 1 = y, 2 = z) in composition order R = R_a R_b R_c
  double range_deg[3][2];      // hinge limits in degrees, same order as `order`
  double kp;                   // actuator stiffness, N m / rad (kd = kp / 10)
};
const std::array<HumanoidJointSpec, kHumanoidBodies>& humanoid_joint_spec();

// World rotation (w,x,y,z, Z-up basis) of canonical joint frame j in the reference pose: Wref_j above.
const std::array<double, 4>& rest_world_rot(int j);
// Position of joint j in the reference pose relative to the hips (metres, world axes); [0] = 0.
const std::array<double, 3>& rest_joint_pos(int j);
// Hips height above the floor in the reference pose with the lowest corner of the (pitched, see humanoid.cpp)
// foot and toes boxes on the floor (metres).
double humanoid_hips_height();
// Rest offsets [21, 3] of the canonical Motion (metres, Z up): the bone offsets of the spec, Hips at its height.
std::vector<float> humanoid_offsets();

struct HumanoidOptions {
  int solver = mjSOL_PGS;           // constraint solver: mjSOL_PGS, mjSOL_NEWTON or mjSOL_CG
  int solver_iterations = 6;        // solver iterations per physics step (PGS stops at this cap on most steps)
  bool euler = true;                // false: implicit integrator
  double floor_friction = 1.0;
  double gain_scale = 1.0;          // multiplies every kp (and kd)
  bool self_collision = false;      // true: body geoms also collide with each other (slower)
  bool elliptic_cones = true;       // friction cones: true = elliptic (3 rows per contact), false = pyramidal (4)
};
// The MJCF text of our humanoid (deterministic for the given options).
std::string humanoid_mjcf(const HumanoidOptions& opt = {});

// Owns an mjModel (read-only after loading) plus the index tables the rest of sim/ needs.
class Humanoid {
 public:
  // Compile an MJCF string / file. Throws t2m::Error with MuJoCo's message on a missing or invalid model.
  static std::shared_ptr<const Humanoid> from_xml(const std::string& xml);
  static std::shared_ptr<const Humanoid> from_file(const std::string& path);
  // Our generated humanoid.
  static std::shared_ptr<const Humanoid> create(const HumanoidOptions& opt = {});

  const mjModel* model() const { return m_; }
  ~Humanoid();
  Humanoid(const Humanoid&) = delete;
  Humanoid& operator=(const Humanoid&) = delete;

  // Tracked bodies: the 21 canonical bodies when the model is our humanoid (is_humanoid()), otherwise every body
  // except the world, in model order. tracked_bodies()[0] is the root used for the heading frame.
  const std::vector<int>& tracked_bodies() const { return bodies_; }
  bool is_humanoid() const { return humanoid_; }
  // For our humanoid: qpos / dof address of hinge k (k = 3 * (j - 1) + i, the i-th hinge of body j).
  int hinge_qpos(int k) const { return hinge_qpos_[k]; }
  int hinge_dof(int k) const { return hinge_dof_[k]; }
  // Free-joint addresses of the root (-1 when the model has none).
  int root_qpos() const { return root_qpos_; }
  int root_dof() const { return root_dof_; }

 private:
  explicit Humanoid(mjModel* m);
  mjModel* m_ = nullptr;
  std::vector<int> bodies_, hinge_qpos_, hinge_dof_;
  bool humanoid_ = false;
  int root_qpos_ = -1, root_dof_ = -1;
};

// Total mass (kg) of a compiled model.
double model_total_mass(const mjModel* m);

}  // namespace t2m::sim
