// bvh.cpp — BVH reader (whole-file, hand-written tokenizer, std::from_chars) and writer (std::to_chars).
#include "sim/bvh.h"


#include <charconv>
#include <cmath>
#include <cstdio>
#include <memory>
#include <unordered_set>

#include "sim/atomic_file.h"
#include "tensor/tensor.h"

namespace t2m::sim {

const char* channel_name(Channel c) {
  switch (c) {
    case Channel::Xposition: return "Xposition";
    case Channel::Yposition: return "Yposition";
    case Channel::Zposition: return "Zposition";
    case Channel::Xrotation: return "Xrotation";
    case Channel::Yrotation: return "Yrotation";
    case Channel::Zrotation: return "Zrotation";
  }
  return "?";
}

int BvhMotion::total_channels() const {
  int n = 0;
  for (const auto& j : joints) n += (int)j.channels.size();
  return n;
}

int BvhMotion::channel_index(int joint) const {
  if (joint < 0 || joint >= (int)joints.size())
    throw Error("BvhMotion::channel_index: joint " + std::to_string(joint) + " out of range [0, " +
                std::to_string(joints.size()) + ")");
  int n = 0;
  for (int j = 0; j < joint; ++j) n += (int)joints[j].channels.size();
  return n;
}

int BvhMotion::find_joint(std::string_view name) const {
  for (size_t j = 0; j < joints.size(); ++j)
    if (joints[j].name == name) return (int)j;
  return -1;
}

namespace {

inline bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }
inline bool is_space(char c) { return is_blank(c) || c == '\n'; }

// Shortens a token for an error message and makes it printable.
std::string show(std::string_view t) {
  std::string out;
  for (char c : t.substr(0, 40)) out += (c >= 32 && c < 127) ? c : '?';
  if (t.size() > 40) out += "...";
  return "'" + out + "'";
}

// Parses a whole token as a finite double; false when it is not one.
bool to_double(std::string_view t, double* v) {
  const char* b = t.data();
  const char* e = b + t.size();
  if (b != e && *b == '+') ++b;
  if (b == e) return false;
  auto r = std::from_chars(b, e, *v);
  return r.ec == std::errc() && r.ptr == e && std::isfinite(*v);
}

struct Parser {
  Parser(std::string_view text, const std::string& nm) : s(text), name(nm) {}
  std::string_view s;
  const std::string& name;
  size_t p = 0;
  int line = 1;
  BvhMotion m;
  std::unordered_set<std::string> names;

  [[noreturn]] void fail(const std::string& msg, int at) const {
    throw Error(name + ":" + std::to_string(at) + ": " + msg);
  }
  void skip_space() {
    while (p < s.size()) {
      char c = s[p];
      if (c == '\n') {
        ++line;
        ++p;
      } else if (is_blank(c)) {
        ++p;
      } else {
        break;
      }
    }
  }
  // Next whitespace-separated token; '{' and '}' are tokens on their own.
  std::string_view next(const char* expecting) {
    skip_space();
    if (p >= s.size()) fail(std::string("unexpected end of file (truncated?), expected ") + expecting, line);
    if (s[p] == '{' || s[p] == '}') return s.substr(p++, 1);
    size_t b = p;
    while (p < s.size() && !is_space(s[p]) && s[p] != '{' && s[p] != '}') ++p;
    return s.substr(b, p - b);
  }
  void expect(std::string_view want) {
    auto t = next(std::string(want).c_str());
    if (t != want) fail("expected '" + std::string(want) + "', got " + show(t), line);
  }
  double number(const char* what) {
    auto t = next(what);
    double v;
    if (!to_double(t, &v)) fail(std::string("bad ") + what + " " + show(t) + " (not a finite number)", line);
    return v;
  }
  int integer(const char* what, long long lo, long long hi) {
    auto t = next(what);
    long long v = 0;
    auto r = std::from_chars(t.data(), t.data() + t.size(), v);
    if (r.ec != std::errc() || r.ptr != t.data() + t.size())
      fail(std::string("bad ") + what + " " + show(t) + " (not an integer)", line);
    if (v < lo || v > hi)
      fail(std::string(what) + " " + std::to_string(v) + " out of range [" + std::to_string(lo) + ", " +
               std::to_string(hi) + "]",
           line);
    return (int)v;
  }
  Channel channel() {
    auto t = next("a channel name");
    static const char* kNames[6] = {"Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation"};
    for (int c = 0; c < 6; ++c)
      if (t == kNames[c]) return (Channel)c;
    fail("unknown channel name " + show(t), line);
  }

  void joint(int parent, int depth) {
    if (depth > kBvhMaxDepth) fail("hierarchy deeper than " + std::to_string(kBvhMaxDepth) + " joints", line);
    if ((int)m.joints.size() >= kBvhMaxJoints) fail("more than " + std::to_string(kBvhMaxJoints) + " joints", line);
    auto nm = next("a joint name");
    if (nm == "{" || nm == "}") fail("missing joint name before '" + std::string(nm) + "'", line);
    if (!names.insert(std::string(nm)).second) fail("duplicate joint name " + show(nm), line);
    const int self = (int)m.joints.size();
    m.joints.push_back({});
    m.joints[self].name = std::string(nm);
    m.joints[self].parent = parent;
    const int open_line = line;
    expect("{");
    bool has_offset = false, has_channels = false;
    for (;;) {
      auto t = next("OFFSET, CHANNELS, JOINT, End Site or '}'");
      if (t == "OFFSET") {
        if (has_offset) fail("second OFFSET in joint " + show(nm), line);
        for (int k = 0; k < 3; ++k) m.joints[self].offset[k] = number("OFFSET value");
        has_offset = true;
      } else if (t == "CHANNELS") {
        if (has_channels) fail("second CHANNELS in joint " + show(nm), line);
        int n = integer("channel count", 0, 6);
        int seen = 0;
        for (int k = 0; k < n; ++k) {
          Channel c = channel();
          if (seen & (1 << int(c))) fail(std::string("channel ") + channel_name(c) + " listed twice in " + show(nm), line);
          seen |= 1 << int(c);
          m.joints[self].channels.push_back(c);
        }
        has_channels = true;
      } else if (t == "JOINT") {
        joint(self, depth + 1);
      } else if (t == "End") {
        expect("Site");
        if (m.joints[self].has_end_site) fail("second End Site in joint " + show(nm), line);
        expect("{");
        expect("OFFSET");
        for (int k = 0; k < 3; ++k) m.joints[self].end_offset[k] = number("End Site OFFSET value");
        expect("}");
        m.joints[self].has_end_site = true;
      } else if (t == "}") {
        break;
      } else if (t == "MOTION" || t == "ROOT") {
        fail("joint " + show(nm) + " opened at line " + std::to_string(open_line) + " is not closed before " +
                 show(t),
             line);
      } else {
        fail("unknown keyword " + show(t) + " in joint " + show(nm), line);
      }
    }
    if (!has_offset) fail("joint " + show(nm) + " has no OFFSET", line);
  }

  void header() {
    skip_space();
    // Tolerate a UTF-8 byte order mark.
    if (s.substr(p, 3) == "\xEF\xBB\xBF") p += 3;
    expect("HIERARCHY");
    expect("ROOT");
    joint(-1, 1);
    auto t = next("MOTION");
    if (t == "ROOT") fail("more than one ROOT (not supported)", line);
    if (t != "MOTION") fail("expected MOTION after the hierarchy, got " + show(t), line);
    t = next("Frames:");
    if (t == "Frames") {
      expect(":");
    } else if (t != "Frames:") {
      fail("expected 'Frames:', got " + show(t), line);
    }
    m.frames = integer("frame count", 0, kBvhMaxFrames);
    expect("Frame");
    t = next("Time:");
    if (t == "Time") {
      expect(":");
    } else if (t != "Time:") {
      fail("expected 'Frame Time:', got " + show(t), line);
    }
    m.frame_time = number("Frame Time");
    if (!(m.frame_time > 0)) fail("Frame Time must be > 0, got " + std::to_string(m.frame_time), line);
    if (m.total_channels() == 0) fail("no CHANNELS in the hierarchy", line);
  }

  void values() {
    const int C = m.total_channels();
    // Every value needs at least 2 bytes ("0 "): refuse a frame count the remaining text cannot hold before
    // allocating anything.
    const long long need = (long long)m.frames * C;
    const long long room = (long long)(s.size() - p) / 2 + 1;
    if (need > room)
      fail("Frames: " + std::to_string(m.frames) + " needs " + std::to_string(need) + " values but only " +
               std::to_string(s.size() - p) + " bytes follow (truncated file or wrong frame count)",
           line);
    m.values.resize((size_t)need);
    double* out = m.values.data();
    const char* end = s.data() + s.size();
    for (int t = 0; t < m.frames; ++t) {
      skip_space();
      if (p >= s.size())
        fail("truncated: file ends after " + std::to_string(t) + " of " + std::to_string(m.frames) + " frames",
             line);
      for (int c = 0; c < C; ++c) {
        while (p < s.size() && is_blank(s[p])) ++p;
        if (p >= s.size() || s[p] == '\n')
          fail("frame " + std::to_string(t) + " has " + std::to_string(c) + " values, expected " +
                   std::to_string(C) + (p >= s.size() ? " (truncated file)" : ""),
               line);
        const char* b = s.data() + p;
        if (*b == '+') ++b;
        double v;
        auto r = std::from_chars(b, end, v);
        if (r.ec != std::errc() || (r.ptr != end && !is_space(*r.ptr)) || !std::isfinite(v)) {
          size_t e = p;
          while (e < s.size() && !is_space(s[e])) ++e;
          fail("frame " + std::to_string(t) + " value " + std::to_string(c) + ": " + show(s.substr(p, e - p)) +
                   " is not a finite number",
               line);
        }
        *out++ = v;
        p = (size_t)(r.ptr - s.data());
      }
      while (p < s.size() && is_blank(s[p])) ++p;
      if (p < s.size() && s[p] != '\n')
        fail("frame " + std::to_string(t) + " has more than " + std::to_string(C) + " values", line);
    }
    skip_space();
    if (p < s.size())
      fail("unexpected data after the " + std::to_string(m.frames) + " frames: " + show(next("")), line);
  }
};

void append_number(std::string& out, double v, int digits) {
  char buf[64];
  auto r = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, digits);
  out.append(buf, r.ptr);
}

}  // namespace

BvhMotion parse_bvh(std::string_view text, const std::string& name_for_errors) {
  Parser ps(text, name_for_errors);
  ps.header();
  ps.values();
  return std::move(ps.m);
}

BvhMotion parse_bvh_header(std::string_view text, const std::string& name_for_errors) {
  Parser ps(text, name_for_errors);
  ps.header();
  return std::move(ps.m);
}

BvhMotion read_bvh(const std::string& path) {
  std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) throw Error("read_bvh: cannot open '" + path + "'");
  std::string text;
  if (std::fseek(f.get(), 0, SEEK_END) == 0) {
    const long size = std::ftell(f.get());
    if (size > 0) text.reserve((size_t)size);
    std::rewind(f.get());
  }
  char buf[1 << 16];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, f.get())) > 0) text.append(buf, n);
  if (std::ferror(f.get())) throw Error("read_bvh: read error on '" + path + "'");
  return parse_bvh(text, path);
}

std::string bvh_to_string(const BvhMotion& m, int digits) {
  if (digits < 1 || digits > 17) throw Error("bvh_to_string: digits " + std::to_string(digits) + " not in [1, 17]");
  if (m.joints.empty()) throw Error("bvh_to_string: no joints");
  const int C = m.total_channels();
  if (m.frames < 0 || (size_t)m.frames * C != m.values.size())
    throw Error("bvh_to_string: values has " + std::to_string(m.values.size()) + " entries, expected frames " +
                std::to_string(m.frames) + " x channels " + std::to_string(C));
  if (!(m.frame_time > 0) || !std::isfinite(m.frame_time))
    throw Error("bvh_to_string: bad frame_time " + std::to_string(m.frame_time));
  for (double v : m.values)
    if (!std::isfinite(v)) throw Error("bvh_to_string: non-finite value in the motion");
  std::string out = "HIERARCHY\n";
  std::vector<int> stack;  // open joints
  auto indent = [&](size_t d) { out.append(d, '\t'); };
  auto close_top = [&]() {
    const BvhJoint& j = m.joints[stack.back()];
    const size_t d = stack.size() - 1;
    if (j.has_end_site) {
      indent(d + 1), out += "End Site\n";
      indent(d + 1), out += "{\n";
      indent(d + 2), out += "OFFSET";
      for (int k = 0; k < 3; ++k) out += ' ', append_number(out, j.end_offset[k], digits);
      out += '\n';
      indent(d + 1), out += "}\n";
    }
    indent(d), out += "}\n";
    stack.pop_back();
  };
  for (size_t i = 0; i < m.joints.size(); ++i) {
    const BvhJoint& j = m.joints[i];
    if (i == 0 ? j.parent != -1 : j.parent < 0 || j.parent >= (int)i)
      throw Error("bvh_to_string: joint " + std::to_string(i) + " '" + j.name + "' has bad parent " +
                  std::to_string(j.parent));
    while (!stack.empty() && stack.back() != j.parent) close_top();
    if (i > 0 && stack.empty())
      throw Error("bvh_to_string: joints are not in depth-first order at '" + j.name + "'");
    if (j.name.empty() || j.name.find_first_of(" \t\r\n{}") != std::string::npos)
      throw Error("bvh_to_string: bad joint name '" + j.name + "'");
    if (j.channels.size() > 6) throw Error("bvh_to_string: joint '" + j.name + "' has more than 6 channels");
    const size_t d = stack.size();
    indent(d), out += (i == 0 ? "ROOT " : "JOINT "), out += j.name, out += '\n';
    indent(d), out += "{\n";
    indent(d + 1), out += "OFFSET";
    for (int k = 0; k < 3; ++k) out += ' ', append_number(out, j.offset[k], digits);
    out += '\n';
    indent(d + 1), out += "CHANNELS ", out += std::to_string(j.channels.size());
    for (Channel c : j.channels) out += ' ', out += channel_name(c);
    out += '\n';
    stack.push_back((int)i);
  }
  while (!stack.empty()) close_top();
  out += "MOTION\nFrames:\t" + std::to_string(m.frames) + "\nFrame Time:\t";
  append_number(out, m.frame_time, digits);
  out += '\n';
  out.reserve(out.size() + m.values.size() * (digits + 3));
  for (int t = 0; t < m.frames; ++t) {
    const double* row = m.frame(t);
    for (int c = 0; c < C; ++c) {
      if (c) out += ' ';
      append_number(out, row[c], digits);
    }
    out += '\n';
  }
  return out;
}

void write_bvh(const BvhMotion& m, const std::string& path, int digits) {
  const std::string text = bvh_to_string(m, digits);
  write_text_atomic(path, text, "write_bvh");
}

}  // namespace t2m::sim
