// pose.cpp — feature row <-> pose copies, joint positions, key frames, normalisation (see pose.h).
#include "models/promotion/pose.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "models/data/features_mirror.h"
#include "tensor/tensor.h"

namespace t2m::promotion {

namespace {

void check_rows(size_t n, int width, const char* who) {
  if (n % (size_t)width != 0)
    throw Error(std::string(who) + ": buffer of " + std::to_string(n) + " floats is not a multiple of " +
                std::to_string(width));
}

void check_stats(const PoseStats& s, const char* who) {
  if ((int)s.mean.size() != kPoseDim || (int)s.std.size() != kPoseDim)
    throw Error(std::string(who) + ": pose stats have " + std::to_string(s.mean.size()) + "/" +
                std::to_string(s.std.size()) + " dims, expected " + std::to_string(kPoseDim));
}

}  // namespace

void pose_from_features(const float* feature_row, float* pose) {
  std::memcpy(pose, feature_row + kPoseFeatureBegin, sizeof(float) * kPoseDim);
}

std::vector<float> pose_from_features(const float* feature_row) {
  std::vector<float> p(kPoseDim);
  pose_from_features(feature_row, p.data());
  return p;
}

std::vector<float> poses_from_features(const std::vector<float>& features) {
  check_rows(features.size(), data::kFeatureDim, "poses_from_features");
  size_t T = features.size() / data::kFeatureDim;
  std::vector<float> out(T * kPoseDim);
  for (size_t t = 0; t < T; ++t) pose_from_features(features.data() + t * data::kFeatureDim, out.data() + t * kPoseDim);
  return out;
}

void pose_into_features(const float* pose, float* feature_row) {
  std::memcpy(feature_row + kPoseFeatureBegin, pose, sizeof(float) * kPoseDim);
}

void joint_positions(const float* pose, float* out) {
  out[0] = 0.f;
  out[1] = 0.f;
  out[2] = pose[kPoseHeight];
  std::memcpy(out + 3, pose + kPoseJoints, sizeof(float) * 3 * (sim::kNumJoints - 1));
}

std::vector<float> joint_positions(const float* pose) {
  std::vector<float> j(3 * sim::kNumJoints);
  joint_positions(pose, j.data());
  return j;
}

std::vector<float> mirror_poses(const std::vector<float>& poses) {
  check_rows(poses.size(), kPoseDim, "mirror_poses");
  size_t N = poses.size() / kPoseDim;
  std::vector<float> row(data::kFeatureDim, 0.f), mirrored(data::kFeatureDim), out(poses.size());
  for (size_t n = 0; n < N; ++n) {
    pose_into_features(poses.data() + n * kPoseDim, row.data());
    data::mirror_feature_rows(row.data(), mirrored.data(), 1);
    pose_from_features(mirrored.data(), out.data() + n * kPoseDim);
  }
  return out;
}

std::vector<int> key_frame_indices(int frames, int k) {
  if (frames < 1 || k < 1)
    throw Error("key_frame_indices: need frames >= 1 and k >= 1, got frames " + std::to_string(frames) + ", k " +
                std::to_string(k));
  std::vector<int> idx(k);
  if (k == 1) {
    idx[0] = frames / 2;
    return idx;
  }
  for (int i = 0; i < k; ++i) idx[i] = (int)std::lround((double)i * (frames - 1) / (k - 1));
  return idx;
}

std::vector<float> key_poses(const std::vector<float>& features, int k) {
  check_rows(features.size(), data::kFeatureDim, "key_poses");
  int T = (int)(features.size() / data::kFeatureDim);
  std::vector<int> idx = key_frame_indices(T, k);
  std::vector<float> out((size_t)k * kPoseDim);
  for (int i = 0; i < k; ++i)
    pose_from_features(features.data() + (size_t)idx[i] * data::kFeatureDim, out.data() + (size_t)i * kPoseDim);
  return out;
}

PoseStats pose_stats_from_feature_stats(const data::FeatureStats& s) {
  if (s.dim() != data::kFeatureDim || (int)s.std.size() != data::kFeatureDim)
    throw Error("pose_stats_from_feature_stats: feature stats have " + std::to_string(s.dim()) +
                " dims, expected " + std::to_string(data::kFeatureDim));
  PoseStats p;
  p.mean.assign(s.mean.begin() + kPoseFeatureBegin, s.mean.begin() + kPoseFeatureBegin + kPoseDim);
  p.std.assign(s.std.begin() + kPoseFeatureBegin, s.std.begin() + kPoseFeatureBegin + kPoseDim);
  return p;
}

void normalize_poses(std::vector<float>& poses, const PoseStats& s) {
  check_stats(s, "normalize_poses");
  check_rows(poses.size(), kPoseDim, "normalize_poses");
  for (size_t i = 0; i < poses.size(); ++i) {
    int d = (int)(i % kPoseDim);
    poses[i] = (poses[i] - s.mean[d]) / s.std[d];
  }
}

void denormalize_poses(std::vector<float>& poses, const PoseStats& s) {
  check_stats(s, "denormalize_poses");
  check_rows(poses.size(), kPoseDim, "denormalize_poses");
  for (size_t i = 0; i < poses.size(); ++i) {
    int d = (int)(i % kPoseDim);
    poses[i] = poses[i] * s.std[d] + s.mean[d];
  }
}

}  // namespace t2m::promotion
