// test_bvh_fuzz.cpp — deterministic mutation fuzzing of the BVH reader and motion_from_bvh: thousands of mutants
// of a real (shortened) Bandai clip and of a hand-written chain; each must parse or throw t2m::Error — never crash,
// hang or throw anything else. Run under the T2M_SANITIZE build to catch memory errors too.
#include <gtest/gtest.h>

#include <fstream>
#include <random>
#include <sstream>

#include "sim/bvh.h"
#include "sim/skeleton.h"
#include "tensor/tensor.h"

using namespace t2m;
using namespace t2m::sim;

namespace {

std::string slurp(const std::string& name) {
  std::ifstream f(std::string(T2M_SOURCE_DIR) + "/tests/fixtures/bvh/" + name, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// The real fixture cut down to its first `frames` frames (keeps every mutant small and fast to parse).
std::string shortened_real(int frames) {
  std::string s = slurp("bandai_walk_60.bvh");
  const size_t fr = s.find("Frames:");
  const size_t eol = s.find('\n', fr);
  s.replace(fr, eol - fr, "Frames: " + std::to_string(frames));
  size_t p = s.find("Frame Time:");
  for (int i = 0; i <= frames; ++i) p = s.find('\n', p) + 1;
  return s.substr(0, p);
}

std::vector<std::string> split_lines(const std::string& s) {
  std::vector<std::string> out;
  size_t b = 0;
  while (b < s.size()) {
    size_t e = s.find('\n', b);
    if (e == std::string::npos) e = s.size();
    out.push_back(s.substr(b, e - b));
    b = e + 1;
  }
  return out;
}

std::string join_lines(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& l : v) s += l + '\n';
  return s;
}

std::string mutate(const std::string& base, std::mt19937_64& rng) {
  std::string s = base;
  auto pick = [&](size_t n) { return n == 0 ? size_t(0) : size_t(rng() % n); };
  static const char kBytes[] = "0123456789{}-+.eE \n\t\rXYZ:\0";
  static const char* kTokens[] = {"1e999", "-1e400", "nan", "inf", "99999999999999999999", "2147483648", "-0",
                                  "{", "}", "JOINT", "End Site", "ROOT", "MOTION", "CHANNELS 7", "CHANNELS -1",
                                  "OFFSET", "Frames: 10000000", "Frames: 999", "Frame Time: 0", "0x10", ""};
  static const char* kNumbers[] = {"0", "-0", "1e300", "-1e-300", "123.25", "-7", "3.4e38", "1e-45", "+5", "720"};
  const int n_mut = 1 + (int)pick(3);
  for (int k = 0; k < n_mut; ++k) {
    switch (pick(9)) {
      case 7:
      case 8: {  // replace a number by another valid number (mostly keeps the file parseable)
        size_t p = pick(s.size());
        while (p < s.size() && !(s[p] >= '0' && s[p] <= '9')) ++p;
        while (p > 0 && s[p - 1] != ' ' && s[p - 1] != '\n' && s[p - 1] != '\t') --p;
        size_t e = p;
        while (e < s.size() && s[e] != ' ' && s[e] != '\n' && s[e] != '\t') ++e;
        s.replace(p, e - p, kNumbers[pick(sizeof kNumbers / sizeof *kNumbers)]);
        break;
      }
      case 0:  // byte flip
        if (!s.empty()) s[pick(s.size())] = (rng() & 1) ? (char)rng() : kBytes[pick(sizeof kBytes - 1)];
        break;
      case 1:  // truncation
        s.resize(pick(s.size() + 1));
        break;
      case 2: {  // delete a line
        auto v = split_lines(s);
        if (!v.empty()) v.erase(v.begin() + pick(v.size()));
        s = join_lines(v);
        break;
      }
      case 3: {  // duplicate a line
        auto v = split_lines(s);
        if (!v.empty()) {
          size_t i = pick(v.size());
          v.insert(v.begin() + i, v[i]);
        }
        s = join_lines(v);
        break;
      }
      case 4: {  // replace a token by a nasty one
        size_t p = pick(s.size());
        size_t e = p;
        while (e < s.size() && s[e] != ' ' && s[e] != '\n' && s[e] != '\t') ++e;
        s.replace(p, e - p, kTokens[pick(sizeof kTokens / sizeof *kTokens)]);
        break;
      }
      case 5: {  // swap two lines
        auto v = split_lines(s);
        if (v.size() > 1) std::swap(v[pick(v.size())], v[pick(v.size())]);
        s = join_lines(v);
        break;
      }
      default:  // insert random bytes
        for (int i = 0, n = 1 + (int)pick(8); i < n; ++i) s.insert(pick(s.size() + 1), 1, (char)rng());
        break;
    }
  }
  return s;
}

// Parses, then converts; counts the outcomes. Anything other than success or t2m::Error fails the test.
struct Outcome {
  int parsed = 0, rejected = 0, converted = 0;
};
void run_one(const std::string& text, Outcome& o) {
  BvhMotion m;
  try {
    m = parse_bvh(text, "mutant.bvh");
  } catch (const Error& e) {
    ++o.rejected;
    ASSERT_EQ(std::string(e.what()).rfind("mutant.bvh:", 0), 0u) << e.what();
    return;
  }
  ++o.parsed;
  ASSERT_EQ(m.values.size(), (size_t)m.frames * m.total_channels());
  try {
    Motion mo = motion_from_bvh(m);
    validate_motion(mo, "fuzz");
    ++o.converted;
    bvh_to_string(bvh_from_motion(mo));
  } catch (const Error&) {
  }
  std::string again = bvh_to_string(m, 17);  // every parsed motion can be written back and read again
  BvhMotion m2 = parse_bvh(again, "again");
  ASSERT_EQ(m2.values, m.values);
}

}  // namespace

TEST(BvhFuzz, MutantsOfARealClipParseOrThrowError) {
  const std::string base = shortened_real(4);
  ASSERT_NO_THROW(motion_from_bvh(parse_bvh(base, "base")));
  std::mt19937_64 rng(20261123);
  Outcome o;
  for (int i = 0; i < 10000; ++i) {
    run_one(mutate(base, rng), o);
    if (HasFatalFailure()) return;
  }
  // The mutation mix must exercise both paths, or the fuzzing tests nothing.
  EXPECT_GT(o.rejected, 2000);
  EXPECT_GT(o.parsed, 500);
  EXPECT_GT(o.converted, 300);
  std::printf("real-clip mutants: %d parsed (%d converted), %d rejected\n", o.parsed, o.converted, o.rejected);
}

TEST(BvhFuzz, MutantsOfAHandWrittenChainParseOrThrowError) {
  const std::string base = slurp("chain3.bvh");
  ASSERT_FALSE(base.empty());
  std::mt19937_64 rng(42);
  Outcome o;
  for (int i = 0; i < 10000; ++i) {
    run_one(mutate(base, rng), o);
    if (HasFatalFailure()) return;
  }
  EXPECT_GT(o.rejected, 2000);
  EXPECT_GT(o.parsed, 500);
  std::printf("chain mutants: %d parsed, %d rejected\n", o.parsed, o.rejected);
}

TEST(BvhFuzz, EveryTruncationOfTheChainIsHandled) {
  const std::string base = slurp("chain3.bvh");
  Outcome o;
  for (size_t n = 0; n <= base.size(); ++n) {
    run_one(base.substr(0, n), o);
    if (HasFatalFailure()) return;
  }
  EXPECT_GE(o.parsed, 1);  // the full file (and cuts inside trailing whitespace)
  EXPECT_GT(o.rejected, (int)base.size() - 5);
}
