// posture_script_set.cpp — key poses of clips + their posecodes and scripts (see posture_script_set.h).
#include "models/promotion/posture_script_set.h"

#include "models/data/features_mirror.h"
#include "models/promotion/pose.h"
#include "models/promotion/posecodes.h"
#include "models/promotion/posture_script.h"
#include "tensor/tensor.h"

namespace t2m::promotion {

const float* PostureScriptSet::pose(int i) const { return poses.data() + (size_t)i * kPoseDim; }

std::vector<int> PostureScriptSet::codes_of(int i) const {
  const int R = num_posecodes();
  return std::vector<int>(codes.begin() + (size_t)i * R, codes.begin() + (size_t)(i + 1) * R);
}

PostureScriptSet build_posture_script_set(const std::vector<data::MotionClip>& clips, int k, bool with_mirrors) {
  if (k < 1) throw Error("build_posture_script_set: k must be >= 1, got " + std::to_string(k));
  PostureScriptSet s;
  s.k = k;
  for (size_t c = 0; c < clips.size(); ++c) {
    const data::MotionClip& clip = clips[c];
    if (clip.frames < 1 || clip.features.size() != (size_t)clip.frames * data::kFeatureDim)
      throw Error("build_posture_script_set: clip " + clip.name + " has " + std::to_string(clip.features.size()) +
                  " feature floats for " + std::to_string(clip.frames) + " frames");
    const std::vector<int> idx = key_frame_indices(clip.frames, k);
    std::vector<float> kp = key_poses(clip.features, k);
    for (int m = 0; m < (with_mirrors ? 2 : 1); ++m) {
      if (m == 1) kp = mirror_poses(kp);
      for (int i = 0; i < k; ++i) {
        const float* p = kp.data() + (size_t)i * kPoseDim;
        std::vector<int> codes = pose_posecodes(p);
        s.poses.insert(s.poses.end(), p, p + kPoseDim);
        s.codes.insert(s.codes.end(), codes.begin(), codes.end());
        s.scripts.push_back(posture_script(codes));
        s.clip.push_back((int)c);
        s.key.push_back(i);
        s.frame.push_back(idx[i]);
        s.mirrored.push_back((uint8_t)m);
      }
    }
  }
  return s;
}

std::vector<std::vector<double>> posecode_frequencies(const PostureScriptSet& s) {
  const auto& rules = posecode_rules();
  std::vector<std::vector<double>> f(rules.size());
  for (size_t r = 0; r < rules.size(); ++r) f[r].assign(rules[r].categories.size(), 0.0);
  const int R = (int)rules.size();
  for (int i = 0; i < s.size(); ++i)
    for (int r = 0; r < R; ++r) f[r][s.codes[(size_t)i * R + r]] += 1.0;
  for (auto& row : f)
    for (double& v : row) v = s.size() ? v / s.size() : 0.0;
  return f;
}

}  // namespace t2m::promotion
