// test_bvh.cpp — BVH reader/writer: hierarchy and values of hand-written and real fixtures, write/read round
// trips, and one test per class of bad input (each must throw t2m::Error with "NAME:LINE:" and a clear reason).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "sim/bvh.h"
#include "tensor/tensor.h"

using namespace t2m;
using namespace t2m::sim;

namespace {

std::string fixture(const std::string& name) { return std::string(T2M_SOURCE_DIR) + "/tests/fixtures/bvh/" + name; }

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

const char* kTiny =
    "HIERARCHY\nROOT A\n{\n OFFSET 0 0 0\n CHANNELS 3 Xposition Yposition Zposition\n"
    " JOINT B\n {\n  OFFSET 1 2 3\n  CHANNELS 1 Yrotation\n  End Site\n  {\n   OFFSET 0 0 1\n  }\n }\n}\n"
    "MOTION\nFrames: 2\nFrame Time: 0.5\n1 2 3 45\n4 5 6 -90\n";

// Parses text and returns the error message ("" when it parsed).
std::string error_of(const std::string& text) {
  try {
    parse_bvh(text, "bad.bvh");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

std::string replace(std::string s, const std::string& from, const std::string& to) {
  size_t p = s.find(from);
  EXPECT_NE(p, std::string::npos) << from;
  if (p != std::string::npos) s.replace(p, from.size(), to);
  return s;
}

}  // namespace

TEST(Bvh, ParsesTinyHierarchyAndValues) {
  BvhMotion m = parse_bvh(kTiny, "tiny");
  ASSERT_EQ(m.joints.size(), 2u);
  EXPECT_EQ(m.joints[0].name, "A");
  EXPECT_EQ(m.joints[0].parent, -1);
  EXPECT_EQ(m.joints[1].name, "B");
  EXPECT_EQ(m.joints[1].parent, 0);
  EXPECT_EQ(m.joints[1].offset[2], 3.0);
  ASSERT_EQ(m.joints[1].channels.size(), 1u);
  EXPECT_EQ(m.joints[1].channels[0], Channel::Yrotation);
  EXPECT_TRUE(m.joints[1].has_end_site);
  EXPECT_FALSE(m.joints[0].has_end_site);
  EXPECT_EQ(m.joints[1].end_offset[2], 1.0);
  EXPECT_EQ(m.frames, 2);
  EXPECT_EQ(m.frame_time, 0.5);
  EXPECT_EQ(m.total_channels(), 4);
  EXPECT_EQ(m.channel_index(1), 3);
  EXPECT_EQ(m.find_joint("B"), 1);
  EXPECT_EQ(m.find_joint("C"), -1);
  EXPECT_THROW(m.channel_index(2), Error);
  std::vector<double> want = {1, 2, 3, 45, 4, 5, 6, -90};
  EXPECT_EQ(m.values, want);
  EXPECT_EQ(m.frame(1)[3], -90.0);
}

TEST(Bvh, RealFixtureHasTheBandaiLayout) {
  BvhMotion m = read_bvh(fixture("bandai_walk_60.bvh"));
  ASSERT_EQ(m.joints.size(), 22u);
  EXPECT_EQ(m.joints[0].name, "joint_Root");
  EXPECT_EQ(m.joints[1].name, "Hips");
  EXPECT_EQ(m.joints[21].name, "Toes_R");
  EXPECT_EQ(m.joints[m.find_joint("Toes_R")].parent, m.find_joint("Foot_R"));
  for (const auto& j : m.joints) {
    ASSERT_EQ(j.channels.size(), 6u) << j.name;
    EXPECT_EQ(j.channels[0], Channel::Xposition);
    EXPECT_EQ(j.channels[3], Channel::Zrotation);
    EXPECT_EQ(j.channels[4], Channel::Xrotation);
    EXPECT_EQ(j.channels[5], Channel::Yrotation);
  }
  EXPECT_EQ(m.frames, 60);
  EXPECT_NEAR(m.frame_time, 1.0 / 30, 1e-6);
  EXPECT_EQ(m.values.size(), 60u * 132);
  // First value of the Hips position in frame 0, as printed in the file.
  EXPECT_EQ(m.frame(0)[6], -1.71443);
  // Header-only parse agrees and leaves values empty.
  BvhMotion h = parse_bvh_header(slurp(fixture("bandai_walk_60.bvh")), "hdr");
  EXPECT_EQ(h.frames, 60);
  EXPECT_EQ(h.joints.size(), 22u);
  EXPECT_TRUE(h.values.empty());
}

TEST(Bvh, WriteReadRoundTripIsExactWith17Digits) {
  BvhMotion a = read_bvh(fixture("bandai_walk_60.bvh"));
  BvhMotion b = parse_bvh(bvh_to_string(a, 17), "rt");
  ASSERT_EQ(a.joints.size(), b.joints.size());
  for (size_t j = 0; j < a.joints.size(); ++j) {
    EXPECT_EQ(a.joints[j].name, b.joints[j].name);
    EXPECT_EQ(a.joints[j].parent, b.joints[j].parent);
    EXPECT_EQ(a.joints[j].channels, b.joints[j].channels);
    EXPECT_EQ(a.joints[j].has_end_site, b.joints[j].has_end_site);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(a.joints[j].offset[k], b.joints[j].offset[k]);
  }
  EXPECT_EQ(a.frames, b.frames);
  EXPECT_EQ(a.frame_time, b.frame_time);
  EXPECT_EQ(a.values, b.values);
}

TEST(Bvh, SixDigitWriteReproducesTheDataValues) {
  // The data is printed with 6 significant digits, so a 6-digit rewrite reads back the same numbers.
  BvhMotion a = read_bvh(fixture("bandai_walk_60.bvh"));
  BvhMotion b = parse_bvh(bvh_to_string(a), "rt6");
  ASSERT_EQ(a.values.size(), b.values.size());
  for (size_t i = 0; i < a.values.size(); ++i) ASSERT_EQ(a.values[i], b.values[i]) << i;
}

TEST(Bvh, WriteBvhIsAtomicAndReadable) {
  BvhMotion a = parse_bvh(kTiny, "tiny");
  const std::string path = ::testing::TempDir() + "t2m_test_bvh_write.bvh";
  write_bvh(a, path);
  BvhMotion b = read_bvh(path);
  EXPECT_EQ(a.values, b.values);
  std::remove(path.c_str());
  EXPECT_THROW(write_bvh(a, "/nonexistent-dir-t2m/x.bvh"), Error);
  EXPECT_THROW(read_bvh("/nonexistent-dir-t2m/x.bvh"), Error);
}

TEST(Bvh, WriterRejectsInconsistentMotions) {
  BvhMotion a = parse_bvh(kTiny, "tiny");
  BvhMotion b = a;
  b.values.pop_back();
  EXPECT_THROW(bvh_to_string(b), Error);
  b = a;
  b.values[0] = std::nan("");
  EXPECT_THROW(bvh_to_string(b), Error);
  b = a;
  b.joints[1].parent = 5;
  EXPECT_THROW(bvh_to_string(b), Error);
  b = a;
  b.joints[1].name = "has space";
  EXPECT_THROW(bvh_to_string(b), Error);
  b = a;
  b.frame_time = 0;
  EXPECT_THROW(bvh_to_string(b), Error);
  EXPECT_THROW(bvh_to_string(a, 0), Error);
  EXPECT_THROW(bvh_to_string(BvhMotion{}), Error);
}

TEST(Bvh, ToleratesCrlfPlusSignsAndFramesOnOneTokenOrTwo) {
  std::string crlf;
  for (char c : std::string(kTiny)) {
    if (c == '\n') crlf += '\r';
    crlf += c;
  }
  EXPECT_EQ(parse_bvh(crlf, "crlf").values.size(), 8u);
  EXPECT_EQ(parse_bvh(replace(kTiny, "1 2 3 45", "+1 2 3 4.5e1"), "plus").values[3], 45.0);
  EXPECT_EQ(parse_bvh(replace(kTiny, "Frames: 2", "Frames : 2"), "sp").frames, 2);
}

TEST(Bvh, ErrorsNameFileAndLine) {
  // Truncated in the values: the message names the file, the line and the problem.
  std::string e = error_of(replace(kTiny, "4 5 6 -90\n", "4 5 6\n"));
  EXPECT_NE(e.find("bad.bvh:20:"), std::string::npos) << e;
  EXPECT_NE(e.find("frame 1 has 3 values, expected 4"), std::string::npos) << e;
  // A frame count the remaining bytes cannot hold is refused before allocating.
  e = error_of(replace(kTiny, "4 5 6 -90\n", "4 5"));
  EXPECT_NE(e.find("bad.bvh:18: Frames: 2 needs 8 values but only"), std::string::npos) << e;
}

TEST(Bvh, RejectsEveryClassOfBadInput) {
  struct Case {
    std::string text, want;
  };
  const std::string t = kTiny;
  std::vector<Case> cases = {
      {"", "unexpected end of file"},
      {t.substr(0, t.find("CHANNELS 3 ") + 11), "unexpected end of file"},
      {replace(t, "HIERARCHY", "HIERARCHX"), "expected 'HIERARCHY'"},
      {replace(t, "MOTION\nFrames: 2\nFrame Time: 0.5\n1 2 3 45\n4 5 6 -90\n", ""), "unexpected end of file"},
      {replace(t, "MOTION", "MOTIONS"), "expected MOTION"},
      {replace(t, "Frames: 2\n", "Frames: 3\n"), "truncated"},
      {replace(t, "Frames: 2\n", "Frames: 1\n"), "unexpected data after the 1 frames"},
      {replace(t, "Frames: 2\n", "Frames: 20000000\n"), "out of range"},
      {replace(t, "Frames: 2\n", "Frames: 9000000\n"), "bytes follow"},
      {replace(t, "Frames: 2\n", "Frames: -1\n"), "out of range"},
      {replace(t, "Frames: 2\n", "Frames: two\n"), "not an integer"},
      {replace(t, "Frame Time: 0.5", "Frame Time: 0"), "must be > 0"},
      {replace(t, "Frame Time: 0.5", "Frame Time: nan"), "not a finite number"},
      {replace(t, "1 2 3 45", "1 2 3 4x5"), "is not a finite number"},
      {replace(t, "1 2 3 45", "1 2 3 nan"), "is not a finite number"},
      {replace(t, "1 2 3 45", "1 2 3 inf"), "is not a finite number"},
      {replace(t, "1 2 3 45", "1 2 3 1e999"), "is not a finite number"},
      {replace(t, "1 2 3 45", "1 2 3 45 6"), "more than 4 values"},
      {replace(t, "1 2 3 45", "1 2 3"), "frame 0 has 3 values"},
      {replace(t, "CHANNELS 1 Yrotation", "CHANNELS 1 Wrotation"), "unknown channel name 'Wrotation'"},
      {replace(t, "CHANNELS 1 Yrotation", "CHANNELS 2 Yrotation"), "unknown channel name 'End'"},
      {replace(t, "CHANNELS 1 Yrotation", "CHANNELS 7 Yrotation"), "channel count 7 out of range"},
      {replace(t, "CHANNELS 1 Yrotation", "CHANNELS 2 Yrotation Yrotation"), "listed twice"},
      {replace(t, "JOINT B", "JOINT A"), "duplicate joint name 'A'"},
      {replace(t, " }\n}\nMOTION", " }\nMOTION"), "is not closed"},
      {replace(t, "OFFSET 1 2 3", "OFFSET 1 2"), "bad OFFSET value"},
      {replace(t, "OFFSET 1 2 3", "OFFSET 1 2 3 4"), "unknown keyword '4'"},
      {replace(t, "OFFSET 1 2 3", "ROTATE 1 2 3"), "unknown keyword 'ROTATE'"},
      {replace(t, "  OFFSET 1 2 3\n", ""), "has no OFFSET"},
      {replace(t, "MOTION", "ROOT C\n{\n OFFSET 0 0 0\n}\nMOTION"), "more than one ROOT"},
      {replace(t, "Frame Time", "Frame Tim"), "expected 'Frame Time:'"},
      {replace(t, "Frames:", "Framez:"), "expected 'Frames:'"},
      {replace(t, "ROOT A\n{", "ROOT A\n("), "expected '{'"},
      {replace(t, "CHANNELS 3 Xposition Yposition Zposition", "CHANNELS 0"), "frame 0 has more than 1 values"},
  };
  for (const auto& c : cases) {
    std::string e = error_of(c.text);
    EXPECT_NE(e.find(c.want), std::string::npos) << "want '" << c.want << "', got '" << e << "' for:\n" << c.text;
    EXPECT_EQ(e.rfind("bad.bvh:", 0), 0u) << e;
  }
}

TEST(Bvh, RejectsTooDeepHierarchyAndNoChannels) {
  std::string deep = "HIERARCHY\nROOT j0\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n";
  for (int d = 1; d <= kBvhMaxDepth; ++d) deep += "JOINT j" + std::to_string(d) + "\n{\nOFFSET 0 0 0\n";
  for (int d = 0; d <= kBvhMaxDepth; ++d) deep += "}\n";
  deep += "MOTION\nFrames: 0\nFrame Time: 1\n";
  EXPECT_NE(error_of(deep).find("deeper than 64"), std::string::npos) << error_of(deep);
  std::string none = "HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\n}\nMOTION\nFrames: 0\nFrame Time: 1\n";
  EXPECT_NE(error_of(none).find("no CHANNELS"), std::string::npos) << error_of(none);
  // Zero frames with channels is a valid (empty) motion.
  std::string empty = "HIERARCHY\nROOT A\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n}\nMOTION\nFrames: 0\nFrame Time: 1\n";
  EXPECT_EQ(parse_bvh(empty, "e").frames, 0);
}
