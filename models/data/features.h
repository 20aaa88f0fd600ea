// features.h — HumanML3D-style per-frame motion features of the canonical 21-joint skeleton, and their exact
// inverse back to joint positions (and rotations).
//
// Input: a sim::Motion (pos [T,21,3] metres Z-up world, rot [T,21,4] local quaternions (w,x,y,z), see
// sim/skeleton.h). Output: row-major float32 [T, kFeatureDim], one row per frame (no frame is dropped).
//
// Heading (yaw) of a pose: across = (p[UpperLeg_L] - p[UpperLeg_R]) + (p[UpperArm_L] - p[UpperArm_R]) (hips and
// shoulders, pointing to the performer's left), forward = across x up = (across_y, -across_x, 0),
// yaw = atan2(forward_y, forward_x). Yaw 0 = facing +X with the left side on +Y (the Bandai walking direction).
// If |forward| < 1e-6 m the previous frame's yaw is kept (0 on frame 0). The heading frame of frame t is the
// world rotated by yaw_t about Z, centred on the root's ground projection (root_x, root_y, 0).
//
// Layout (D = 257; "per frame" quantities are differences between frame t-1 and t; frame 0 copies frame 1,
// or 0 when T == 1; the inverse never reads frame 0's differences):
//   [0]        root angular velocity about +Z: wrap(yaw_t - yaw_{t-1}), radians per frame, in (-pi, pi]
//   [1, 3)     root planar velocity in the heading frame of t: Rz(-yaw_t) (root_t - root_{t-1})_xy, m per frame
//   [3]        root height: root_t.z, metres (world)
//   [4, 64)    joints 1..20: (x, y) = Rz(-yaw_t) (p_j - root)_xy, z = p_j.z (world height), metres, joint order
//   [64, 190)  6D rotations (first two columns of R, (R00,R10,R20,R01,R11,R21)) of all 21 joints: joint 0 is the
//              Hips rotation in the heading frame, Rz(-yaw_t) R_hips; joints 1..20 are the local rotations
//   [190, 253) velocities of all 21 joints in the heading frame of t: Rz(-yaw_t) (p_j,t - p_j,t-1), m per frame
//   [253, 257) foot contacts (0/1) of Foot_L, Toes_L, Foot_R, Toes_R: height above the joint's lowest point in the
//              clip < contact_height AND speed |p_t - p_{t-1}| * fps < contact_speed
// The features do not depend on the world yaw and planar position of the clip.
//
// Inverse: yaw_0 = 0, root_0 = (0, 0); yaw_t = yaw_{t-1} + f[t,0]; root_t = root_{t-1} + Rz(yaw_t) f[t,1:3];
// p_j = Rz(yaw_t) (x, y) + root_t, z as stored. It returns the motion in its canonical frame: the input with the
// frame-0 root moved to x = y = 0 and the frame-0 heading turned to yaw 0 (see canonicalize_motion); computed in
// double precision, the round trip is exact up to float32 rounding of the features.
//
// Errors: t2m::Error naming the function and the sizes when pos/rot sizes do not match frames, frames < 1,
// fps <= 0, or a feature buffer is not a multiple of kFeatureDim.
#pragma once
#include <vector>

#include "sim/skeleton.h"

namespace t2m::data {

inline constexpr int kFeatureJoints = sim::kNumJoints;  // 21
inline constexpr int kFeatRootYawVel = 0;
inline constexpr int kFeatRootVel = 1;                  // 2 dims
inline constexpr int kFeatRootHeight = 3;
inline constexpr int kFeatLocalPos = 4;                 // 20 joints x 3
inline constexpr int kFeatRot6d = 64;                   // 21 joints x 6
inline constexpr int kFeatJointVel = 190;               // 21 joints x 3
inline constexpr int kFeatContact = 253;                // 4: Foot_L, Toes_L, Foot_R, Toes_R
inline constexpr int kFeatureDim = 257;
inline constexpr int kContactJoints[4] = {sim::kFootL, sim::kToesL, sim::kFootR, sim::kToesR};

struct FeatureConfig {
  double contact_height = 0.05;  // metres above the joint's lowest height in the clip
  double contact_speed = 0.6;    // metres per second
};

// Heading yaw (radians) of one pose [21, 3]; `fallback` when the across vector is (nearly) vertical.
double heading_yaw(const float* pose, double fallback = 0.0);

// Motion -> features [T, kFeatureDim] (row-major). Throws t2m::Error on inconsistent sizes.
std::vector<float> motion_to_features(const sim::Motion& m, const FeatureConfig& cfg = {});

// Features [T, kFeatureDim] -> joint positions [T, 21, 3] in the canonical frame. T = f.size() / kFeatureDim.
std::vector<float> features_to_positions(const std::vector<float>& f);
// Features -> rotations [T, 21, 4] (w,x,y,z, w >= 0): 6D -> matrix by Gram-Schmidt; the Hips gets its yaw back.
std::vector<float> features_to_rotations(const std::vector<float>& f);

// The motion moved so that the frame-0 root is at x = y = 0 and the frame-0 heading is yaw 0 (rotation about Z
// around the frame-0 root's ground point; heights unchanged). pos and the Hips rotation change; offsets do not.
sim::Motion canonicalize_motion(const sim::Motion& m);

// Rotates (about +Z by `yaw`) and then translates (by dx, dy) a whole motion in the world: pos and Hips rotation.
void transform_motion(sim::Motion& m, double yaw, double dx, double dy);

// Checks frames >= 1, fps > 0 and the pos/rot sizes; throws t2m::Error naming `who`.
void check_motion(const sim::Motion& m, const char* who);

}  // namespace t2m::data
