// pose.h — the single-pose representation of the PRO-Motion baseline (posture scripts, posture diffuser, posture
// planning, go-diffuser key-pose tokens): one frame of the motion features (models/data/features.h) restricted to
// the body, i.e. without the root's yaw velocity, planar velocity, joint velocities and foot contacts.
//
// Layout (kPoseDim = 187 floats; feature dims in brackets):
//   [0]         root (Hips) height, metres                                    feature [3]
//   [1, 61)     joints 1..20: (x, y) relative to the root's ground point in the root's heading frame
//               (x forward, y to the performer's left), z = height above the floor, metres   feature [4, 64)
//   [61, 187)   6D rotations of all 21 joints (joint 0 = Hips in the heading frame, others local)  feature [64, 190)
// Joint positions in this frame: root = (0, 0, height), joint j = pose[1 + 3 (j - 1) ..] (j = 1..20), i.e. a
// pose is invariant to the clip's world position and heading; heights are absolute (the floor is z = 0).
//
// Key frames: K frames of a clip, evenly spaced including the first and the last,
//   frame_i = round(i (T - 1) / (K - 1)),  i = 0..K-1   (K = 1: the middle frame T / 2; T < K repeats frames).
// Normalisation: PoseStats = per-dim mean / std of the pose dims, taken from the train-split feature stats
// (data::clip_feature_stats over all train frames and their mirrors: mirror-symmetric); normalise (x - mean) / std.
// Mirror: the data's left/right mirror (features_mirror.h) restricted to the pose dims.
// Errors: t2m::Error naming the function and the sizes (row buffers not a multiple of the width, frames < 1, K < 1,
// stats of the wrong dimension).
#pragma once
#include <cstdint>
#include <vector>

#include "models/data/features.h"
#include "models/data/features_norm.h"

namespace t2m::promotion {

inline constexpr int kPoseDim = 187;
inline constexpr int kPoseHeight = 0;      // 1 dim
inline constexpr int kPoseJoints = 1;      // 20 joints x 3 (joints 1..20)
inline constexpr int kPoseRot6d = 61;      // 21 joints x 6
inline constexpr int kPoseFeatureBegin = data::kFeatRootHeight;  // 3: pose = features [3, 190)
inline constexpr int kDefaultKeyFrames = 8;
static_assert(data::kFeatJointVel - data::kFeatRootHeight == kPoseDim, "pose = feature dims [3, 190)");

// One feature row [kFeatureDim] -> one pose [kPoseDim] (copy of dims [3, 190)).
void pose_from_features(const float* feature_row, float* pose);
std::vector<float> pose_from_features(const float* feature_row);
// Rows [T, kFeatureDim] -> poses [T, kPoseDim]. Throws when the buffer is not a multiple of kFeatureDim.
std::vector<float> poses_from_features(const std::vector<float>& features);
// Writes a pose into dims [3, 190) of a feature row; the other dims are left as they are.
void pose_into_features(const float* pose, float* feature_row);

// Joint positions [21, 3] (metres, heading frame, root at (0, 0, height)) of one pose.
void joint_positions(const float* pose, float* out_21x3);
std::vector<float> joint_positions(const float* pose);

// Left/right mirror of poses [N, kPoseDim] (the data's mirror restricted to the pose dims).
std::vector<float> mirror_poses(const std::vector<float>& poses);

// Key-frame indices of a clip of `frames` frames (rule above). Throws on frames < 1 or k < 1.
std::vector<int> key_frame_indices(int frames, int k = kDefaultKeyFrames);
// The K key poses [K, kPoseDim] of a clip's raw features [frames, kFeatureDim].
std::vector<float> key_poses(const std::vector<float>& features, int k = kDefaultKeyFrames);

struct PoseStats {
  std::vector<float> mean, std;  // [kPoseDim] each
};
// The pose dims of feature stats (dim must be kFeatureDim).
PoseStats pose_stats_from_feature_stats(const data::FeatureStats& s);
void normalize_poses(std::vector<float>& poses, const PoseStats& s);    // in place, [N, kPoseDim]
void denormalize_poses(std::vector<float>& poses, const PoseStats& s);  // in place, [N, kPoseDim]

}  // namespace t2m::promotion
