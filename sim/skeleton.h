// skeleton.h — the canonical skeleton of t2m-engine and forward kinematics (FK).
//
// Joints (21, the Bandai joints minus the always-zero joint_Root), index: name (parent)
//    0 Hips (-1)        1 Spine (0)        2 Chest (1)        3 Neck (2)         4 Head (3)
//    5 Shoulder_L (2)   6 UpperArm_L (5)   7 LowerArm_L (6)   8 Hand_L (7)
//    9 Shoulder_R (2)  10 UpperArm_R (9)  11 LowerArm_R (10) 12 Hand_R (11)
//   13 UpperLeg_L (0)  14 LowerLeg_L (13) 15 Foot_L (14)     16 Toes_L (15)
//   17 UpperLeg_R (0)  18 LowerLeg_R (17) 19 Foot_R (18)     20 Toes_R (19)
// (parent < child; this is the BVH depth-first order.) _L is the performer's left.
//
// World frame: metres, Z up, right-handed (MuJoCo convention). Change of basis from the BVH (cm, Y up):
//     (x, y, z)_world = (z, x, y)_bvh / 100        (a cyclic axis permutation P, det +1: a proper rotation)
// The Bandai performers walk forward along +Z_bvh, which becomes +X_world; their left (+X_bvh) is +Y_world.
// Rotations change basis by conjugation R_world = P R_bvh P^T (quaternion: w unchanged, vector part permuted).
//
// Rotations are unit quaternions (w, x, y, z). rot[t, j] is joint j's LOCAL rotation relative to its parent's
// frame, in the Z-up basis; rot[t, 0] (Hips) is the world orientation of the Hips frame. The rest pose (all rot
// identity) is the BVH zero pose of the data: the joint frames are those of the file (the Bandai joints have
// their bone along the local x axis), so identity rotations are NOT a T-pose; world-space quantities come from pos.
// offsets[j] = joint j's rest offset from its parent, metres, in the parent's (Z-up-converted) frame;
// offsets[0] = the Hips OFFSET of the file (kept only for export; root motion lives in pos[t, 0]).
// FK (the invariant of a Motion):  W_0 = rot_0,  W_j = W_parent(j) rot_j,
//                                  pos_0 = root translation,  pos_j = pos_parent(j) + W_parent(j) offsets_j.
#pragma once
#include <array>
#include <string>
#include <vector>

#include "sim/bvh.h"

namespace t2m::sim {

inline constexpr int kNumJoints = 21;
inline constexpr double kCanonicalFps = 30.0;
enum JointId : int {
  kHips, kSpine, kChest, kNeck, kHead,
  kShoulderL, kUpperArmL, kLowerArmL, kHandL,
  kShoulderR, kUpperArmR, kLowerArmR, kHandR,
  kUpperLegL, kLowerLegL, kFootL, kToesL,
  kUpperLegR, kLowerLegR, kFootR, kToesR,
};
extern const std::array<const char*, kNumJoints> kJointNames;  // the BVH names above
extern const std::array<int, kNumJoints> kJointParents;         // -1 for Hips
extern const std::array<int, kNumJoints> kJointMirror;          // left <-> right partner (self for centre joints)
int joint_index(const std::string& name);                        // -1 when not a canonical joint

struct Motion {
  int frames = 0;
  double fps = kCanonicalFps;
  std::vector<float> pos;      // [T, 21, 3] world joint positions, metres, Z up
  std::vector<float> rot;      // [T, 21, 4] local joint rotations (w, x, y, z), Z-up basis
  std::vector<float> offsets;  // [21, 3] rest offsets, metres, Z-up basis (see above)
};

// BVH (any channel order; position channels replace OFFSET components) -> canonical Motion.
// Needs every canonical joint by name with the canonical parent table; joints above Hips (e.g. joint_Root) have
// their transforms folded into the Hips world transform; other extra joints are ignored. Any rotation channel
// order/count (none = identity). Position channels move Hips (and the joints above it); for the other joints the
// OFFSET is used (the data repeats OFFSET in their position channels).
// fps = 1 / frame_time (the Bandai data is 30 fps; no resampling). pos is computed with sim FK from rot, offsets and
// the Hips translation, so the Motion invariant holds exactly (up to float rounding).
// Throws t2m::Error naming the file's missing joints / bad channel layout.
Motion motion_from_bvh(const BvhMotion& bvh);

// Canonical Motion -> BVH with the data's layout: joint_Root (zero) + the 21 joints, every joint 6 channels
// "Xposition Yposition Zposition Zrotation Xrotation Yrotation", cm, Y up, End Sites (zero offset) on Head, Hands
// and Toes, Frame Time 1/fps. Position channels of non-root joints hold their OFFSET. Throws on bad sizes.
BvhMotion bvh_from_motion(const Motion& m);

// Generic FK for one pose: J joints, parents[j] < j (-1 for the root, only joint 0), rot [J,4] local (w,x,y,z)
// (need not be normalised: normalised internally), offsets [J,3], root_pos [3]; writes pos_out [J,3] and, when
// not null, world_rot_out [J,4]. Units are whatever offsets/root_pos use. Throws on a bad parent table.
void forward_kinematics(const float* rot, const float* offsets, const int* parents, int J, const float* root_pos,
                        float* pos_out, float* world_rot_out = nullptr);
// Recomputes m.pos[t, 1:] from m.rot, m.offsets and m.pos[t, 0] for every frame (the Motion invariant).
void motion_fk(Motion& m);
// Checks sizes (pos T*63, rot T*84, offsets 63, frames >= 0, fps > 0, finite values); throws t2m::Error.
void validate_motion(const Motion& m, const std::string& what);

// Basis change helpers (see above). Vectors: bvh cm Y-up <-> world m Z-up. Quaternions (w,x,y,z): basis only.
void bvh_to_world_vec(const double in_cm[3], double out_m[3]);
void world_to_bvh_vec(const double in_m[3], double out_cm[3]);
void bvh_to_world_quat(const double in[4], double out[4]);
void world_to_bvh_quat(const double in[4], double out[4]);
// Euler angles (degrees) for rotation channels in the given order -> quaternion (w,x,y,z), R = R_c0 R_c1 R_c2;
// and the inverse for the order Z, X, Y (the data's order), returning degrees (z, x, y).
void quat_from_euler_deg(const Channel* order, const double* deg, int n, double out[4]);
void quat_to_euler_zxy_deg(const double q[4], double out_deg_zxy[3]);

}  // namespace t2m::sim
