// bvh.h — Biovision Hierarchy (BVH) motion files: reader and writer.
//
// A BvhMotion is the file as written: the joint hierarchy (depth-first, in file order) and the MOTION block as one
// row-major array `values` of shape [frames, total_channels]. No unit or axis conversion happens here (the Bandai
// data is centimetres, Y up, degrees); sim/skeleton.h turns it into the canonical Z-up metre skeleton.
//
// Semantics assumed by the rest of the project (the common BVH reading, and what the Bandai files need):
//   - rotation channels are degrees; the local rotation is the product of the elementary rotations in the order
//     the channels are listed (e.g. "Zrotation Xrotation Yrotation" -> R = Rz * Rx * Ry, column vectors);
//   - a position channel REPLACES the matching component of OFFSET for that joint (the Bandai root translation is
//     in the Hips position channels; the other joints' position channels repeat their OFFSET).
//
// Reader: reads the whole file, hand-written tokenizer, std::from_chars for numbers. Never crashes on any input;
// every problem throws t2m::Error("NAME:LINE: message"), NAME being the path (or the name given to parse_bvh):
// truncated file, bad braces, unknown keyword or channel name, wrong channel count, non-numeric / NaN / Inf values,
// missing MOTION section, frame count < 0, > kBvhMaxFrames or larger than the data present, fewer or more values
// than frames x channels, duplicate joint names, more than one ROOT, hierarchy deeper than kBvhMaxDepth or with more
// than kBvhMaxJoints joints, non-positive or non-finite Frame Time.
// Writer: the same layout (tabs for indentation), numbers with `digits` significant digits (%.{digits}g style,
// shortest form, default 6 = the precision of the Bandai files); write_bvh writes PATH.tmp.PID then renames it
// (atomic on POSIX), and throws t2m::Error when the file cannot be written.
#pragma once
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace t2m::sim {

inline constexpr int kBvhMaxFrames = 10'000'000;
inline constexpr int kBvhMaxDepth = 64;
inline constexpr int kBvhMaxJoints = 1024;

enum class Channel : uint8_t { Xposition, Yposition, Zposition, Xrotation, Yrotation, Zrotation };
const char* channel_name(Channel c);                 // "Xposition", ...
inline bool is_rotation(Channel c) { return c >= Channel::Xrotation; }
inline int channel_axis(Channel c) { return int(c) % 3; }  // 0 = X, 1 = Y, 2 = Z

struct BvhJoint {
  std::string name;
  int parent = -1;                                   // index into BvhMotion::joints; -1 for the root; parent < self
  double offset[3] = {0, 0, 0};                      // file units (Bandai: cm), in the parent's frame
  std::vector<Channel> channels;                     // 0..6 channels, file order
  bool has_end_site = false;
  double end_offset[3] = {0, 0, 0};                  // End Site OFFSET (valid when has_end_site)
};

struct BvhMotion {
  std::vector<BvhJoint> joints;                      // depth-first file order; joints[0] is the ROOT
  int frames = 0;
  double frame_time = 0;                             // seconds per frame (Bandai: 0.0333333)
  std::vector<double> values;                        // [frames, total_channels] row-major, file units / degrees

  int total_channels() const;                        // sum of channels over joints
  int channel_index(int joint) const;                // column of the joint's first channel within a frame row
  int find_joint(std::string_view name) const;       // index or -1
  const double* frame(int t) const { return values.data() + (size_t)t * total_channels(); }
  double* frame(int t) { return values.data() + (size_t)t * total_channels(); }
};

BvhMotion read_bvh(const std::string& path);                                    // throws t2m::Error
BvhMotion parse_bvh(std::string_view text, const std::string& name_for_errors);  // throws t2m::Error
// Parses only HIERARCHY and the "Frames:" / "Frame Time:" header (values stays empty): fast, for manifests.
BvhMotion parse_bvh_header(std::string_view text, const std::string& name_for_errors);

std::string bvh_to_string(const BvhMotion& m, int digits = 6);  // throws t2m::Error on inconsistent sizes
void write_bvh(const BvhMotion& m, const std::string& path, int digits = 6);

}  // namespace t2m::sim
