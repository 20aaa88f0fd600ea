// test_splits.cpp — split rule, proportions, stability under input order and added clips, JSON round trip.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <map>
#include <cstdio>
#include <fstream>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "models/data/splits.h"
#include "tensor/tensor.h"

using namespace t2m::data;

namespace {

std::vector<std::string> real_clip_names() {
  std::ifstream f(std::string(T2M_SOURCE_DIR) + "/tests/fixtures/data/bandai_clips.txt");
  std::vector<std::string> out;
  for (std::string line; std::getline(f, line);)
    if (!line.empty()) out.push_back(line);
  return out;
}

std::vector<std::string> synthetic_names(int takes) {
  std::vector<std::string> out;
  for (const char* c : {"walk", "run", "wave-left-hand"})
    for (const char* s : {"normal", "elderly"})
      for (int t = 1; t <= takes; ++t) {
        char buf[16];
        std::snprintf(buf, sizeof buf, "%03d", t);
        out.push_back(std::string("dataset-2_") + c + "_" + s + "_" + buf);
      }
  return out;
}

}  // namespace

TEST(Splits, ParseClipName) {
  ClipName c = clip_name_parts("dataset-2_walk-turn-left_elderly_017");
  EXPECT_EQ(c.dataset, "dataset-2");
  EXPECT_EQ(c.content, "walk-turn-left");
  EXPECT_EQ(c.style, "elderly");
  EXPECT_EQ(c.take, "017");
  EXPECT_EQ(clip_group(c), "dataset-2_walk-turn-left_elderly");
}

TEST(Splits, BadNamesThrow) {
  EXPECT_THROW(clip_name_parts("dataset-2_walk_elderly"), t2m::Error);
  EXPECT_THROW(clip_name_parts("dataset-2_walk__001"), t2m::Error);
  EXPECT_THROW(clip_name_parts("a_b_c_d_e"), t2m::Error);
  EXPECT_THROW(assign_splits({"dataset-2_walk_normal_001", "dataset-2_walk_normal_001"}), t2m::Error);
  EXPECT_THROW(split_from_name("training"), t2m::Error);
  EXPECT_THROW(splits_from_json("{\"format\": \"t2m-splits-1\"}"), t2m::Error);
  EXPECT_THROW(splits_from_json("{\"format\": \"t2m-splits-1\", \"clips\": {\"x\": \"dev\"}}"), t2m::Error);
  EXPECT_THROW(splits_from_json("not json"), t2m::Error);
  EXPECT_THROW(load_splits("/nonexistent/dir/splits.json"), t2m::Error);
}

TEST(Splits, KeyIsUniformish) {
  // 20000 names, numeric takes (Weyl keys) and non-numeric takes (hash keys): the key histogram over 10 bins is
  // within 10% of flat.
  for (const char* prefix : {"dataset-2_walk_normal_", "dataset-2_walk_normal_x"}) {
    int bins[10] = {0};
    for (int i = 0; i < 20000; ++i) {
      double u = split_key(prefix + std::to_string(i));
      ASSERT_GE(u, 0.0);
      ASSERT_LT(u, 1.0);
      bins[int(u * 10)]++;
    }
    for (int b : bins) EXPECT_NEAR(b, 2000, 200) << prefix;
  }
  // The key depends on the name only: same name, same key; different group, different offset.
  EXPECT_EQ(split_key("dataset-2_run_active_003"), split_key("dataset-2_run_active_003"));
  EXPECT_NE(split_key("dataset-2_run_active_003"), split_key("dataset-2_run_elderly_003"));
}

TEST(Splits, LargeGroupFollowsKeyThresholds) {
  auto names = synthetic_names(40);
  auto s = assign_splits(names);
  ASSERT_EQ(s.size(), names.size());
  for (const auto& n : names) {
    double u = split_key(n);
    Split want = u < 0.8 ? Split::train : (u < 0.9 ? Split::val : Split::test);
    EXPECT_EQ(s.at(n), want) << n;
  }
}

TEST(Splits, SmallGroupRule) {
  // 1 take -> train; 2 -> one train one test; 5 -> 1 test, 1 val, 3 train (largest keys go to test then val).
  auto one = assign_splits({"dataset-1_kick_normal_001"});
  EXPECT_EQ(one.at("dataset-1_kick_normal_001"), Split::train);
  auto two = assign_splits({"dataset-1_walk_sad_001", "dataset-1_walk_sad_002"});
  std::string hi = split_key("dataset-1_walk_sad_001") > split_key("dataset-1_walk_sad_002") ? "dataset-1_walk_sad_001"
                                                                                             : "dataset-1_walk_sad_002";
  EXPECT_EQ(two.at(hi), Split::test);
  EXPECT_EQ(clips_in(two, Split::train).size(), 1u);
  std::vector<std::string> five;
  for (int t = 1; t <= 5; ++t) five.push_back("dataset-1_bow_happy_00" + std::to_string(t));
  auto s5 = assign_splits(five);
  EXPECT_EQ(clips_in(s5, Split::test).size(), 1u);
  EXPECT_EQ(clips_in(s5, Split::val).size(), 1u);
  EXPECT_EQ(clips_in(s5, Split::train).size(), 3u);
  std::vector<std::string> by_key = five;
  std::sort(by_key.begin(), by_key.end(), [](auto& a, auto& b) { return split_key(a) > split_key(b); });
  EXPECT_EQ(s5.at(by_key[0]), Split::test);
  EXPECT_EQ(s5.at(by_key[1]), Split::val);
}

TEST(Splits, OrderIndependentAndByteIdenticalFile) {
  auto names = synthetic_names(40);
  auto shuffled = names;
  std::mt19937 g(7);
  std::shuffle(shuffled.begin(), shuffled.end(), g);
  auto a = assign_splits(names), b = assign_splits(shuffled);
  EXPECT_EQ(a, b);
  std::string path = ::testing::TempDir() + "/t2m_splits_test.json";
  save_splits(a, path);
  std::ifstream f1(path);
  std::string first((std::istreambuf_iterator<char>(f1)), {});
  save_splits(b, path);
  std::ifstream f2(path);
  std::string second((std::istreambuf_iterator<char>(f2)), {});
  EXPECT_EQ(first, second);
  EXPECT_EQ(load_splits(path), a);
  std::remove(path.c_str());
}

TEST(Splits, AddingAClipDoesNotMoveOthersInLargeGroups) {
  auto names = synthetic_names(40);
  auto before = assign_splits(names);
  names.push_back("dataset-2_walk_normal_041");
  names.push_back("dataset-2_run_elderly_999");
  auto after = assign_splits(names);
  for (const auto& [n, s] : before) EXPECT_EQ(after.at(n), s) << n;
}

TEST(Splits, RealClipListProportions) {
  auto names = real_clip_names();
  if (names.empty()) GTEST_SKIP() << "tests/fixtures/data/bandai_clips.txt missing";
  ASSERT_EQ(names.size(), 2785u);
  auto s = assign_splits(names);
  // Every dataset-2 content x style pair: ~80/10/10, and at least one train clip in every pair of both sets.
  std::map<std::string, std::array<int, 3>> per_group;
  for (const auto& [n, v] : s) per_group[clip_group(clip_name_parts(n))][(int)v]++;
  int d2_counts[3] = {0, 0, 0};
  for (const auto& [g, c] : per_group) {
    EXPECT_GE(c[0], 1) << g;
    int total = c[0] + c[1] + c[2];
    if (total >= kSplitLargeGroup) {
      // Every large pair within 3 clips of 10% val and 10% test (pure per-clip hashing would miss by ~2 sigma = 6).
      EXPECT_NEAR(c[1], 0.1 * total, 3.0) << g;
      EXPECT_NEAR(c[2], 0.1 * total, 3.0) << g;
      for (int k = 0; k < 3; ++k) d2_counts[k] += c[k];
    }
  }
  int d2 = d2_counts[0] + d2_counts[1] + d2_counts[2];
  ASSERT_EQ(d2, 2611);
  EXPECT_NEAR(d2_counts[0] / double(d2), 0.8, 0.03);
  EXPECT_NEAR(d2_counts[1] / double(d2), 0.1, 0.03);
  EXPECT_NEAR(d2_counts[2] / double(d2), 0.1, 0.03);
  // Removing 10% of clips at random leaves every other dataset-2 clip where it was.
  std::vector<std::string> fewer;
  for (size_t i = 0; i < names.size(); ++i)
    if (i % 10 != 3) fewer.push_back(names[i]);
  auto s2 = assign_splits(fewer);
  for (const auto& n : fewer)
    if (n.rfind("dataset-2", 0) == 0) {
      EXPECT_EQ(s2.at(n), s.at(n)) << n;
    }
}

TEST(Splits, RealAssignmentMatchesTheCommittedFile) {
  // tests/fixtures/data/bandai_splits.json is the assignment of the 2,785 clip names, committed when the rule was
  // fixed: any change of the rule or of the JSON layout shows up here (stable across runs and machines).
  auto names = real_clip_names();
  if (names.empty()) GTEST_SKIP() << "tests/fixtures/data/bandai_clips.txt missing";
  std::ifstream f(std::string(T2M_SOURCE_DIR) + "/tests/fixtures/data/bandai_splits.json");
  ASSERT_TRUE(f.good());
  std::string committed((std::istreambuf_iterator<char>(f)), {});
  EXPECT_EQ(splits_to_json(assign_splits(names)), committed);
  auto loaded = splits_from_json(committed);
  EXPECT_EQ(clips_in(loaded, Split::train).size(), 2243u);
  EXPECT_EQ(clips_in(loaded, Split::val).size(), 268u);
  EXPECT_EQ(clips_in(loaded, Split::test).size(), 274u);
}
