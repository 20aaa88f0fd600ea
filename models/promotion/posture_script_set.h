// posture_script_set.h — our PoseScript-style set: the key poses of the Bandai clips of one split, each with its
// posecodes and automatic posture script (PoseScript-A's role in PRO-Motion, appendix D). Computed on the fly
// (loading a split's clips dominates: ~5 s for the train split; the posecodes of 36k poses take well under 1 s).
//
// Items: for every clip (in the given order) the K key frames of pose.h key_frame_indices, then, with mirrors,
// the same K frames of the mirrored clip (the data's left/right mirror, posecodes recomputed on the mirrored pose).
// Layout: poses [N, kPoseDim] raw (unnormalised), codes [N, num_posecodes()], scripts [N]; per item the clip
// index, key index (0..K-1), frame and the mirror flag.
// Statistics: for every rule the fraction of items in each category (posecode_frequencies).
// Errors: t2m::Error for k < 1 or a clip whose features are not frames x kFeatureDim.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "models/data/loader.h"

namespace t2m::promotion {

struct PostureScriptSet {
  int k = 0;                          // key frames per clip
  std::vector<float> poses;           // [N, kPoseDim]
  std::vector<int> codes;             // [N, num_posecodes()]
  std::vector<std::string> scripts;   // [N]
  std::vector<int> clip, key, frame;  // [N]
  std::vector<uint8_t> mirrored;      // [N]
  int size() const { return (int)scripts.size(); }
  const float* pose(int i) const;
  std::vector<int> codes_of(int i) const;
};

PostureScriptSet build_posture_script_set(const std::vector<data::MotionClip>& clips, int k, bool with_mirrors);

// freq[r][c] = fraction of the set's items whose rule r has category c.
std::vector<std::vector<double>> posecode_frequencies(const PostureScriptSet& s);

}  // namespace t2m::promotion
