// test_promotion_planner.cpp — the rule/template planner: clause splitting, content/style matching, key-frame
// allocation, the left/right modifier, unknown words, determinism, table mining and the table file.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "models/data/features.h"
#include "models/promotion/planner.h"
#include "models/promotion/pose.h"
#include "models/promotion/posecodes.h"
#include "models/promotion/posture_script.h"
#include "tensor/tensor.h"
#include "test_features_synthetic.h"
#include "test_promotion_poses.h"

namespace {

using namespace t2m;
using namespace t2m::promotion;
using namespace t2m::sim;
using t2m::testing::Joints;
using t2m::testing::standing;
using Words = std::vector<std::string>;

// A hand-made table: neutral standing, walk (alternating steps), a right kick, left/right waves, a tired walk.
PlannerTable toy_table() {
  PlannerTable t;
  t.k = 8;
  const std::vector<int> stand = compute_posecodes(standing().data());
  Joints step = standing();
  step.set(kFootL, 0.40f, 0.10f, 0.08f);
  Joints kick = standing();
  kick.set(kLowerLegR, 0.30f, -0.10f, 0.70f);
  kick.set(kFootR, 0.70f, -0.10f, 0.75f);
  kick.set(kToesR, 0.80f, -0.10f, 0.80f);
  Joints wave = standing();
  wave.set(kLowerArmL, 0, 0.40f, 1.55f);
  wave.set(kHandL, 0, 0.45f, 1.85f);
  Joints bent = standing();
  bent.set(kLowerLegL, 0.15f, 0.10f, 0.52f);
  bent.set(kLowerLegR, 0.15f, -0.10f, 0.52f);
  auto codes = [](const Joints& j) { return compute_posecodes(j.data()); };
  t.entries[""] = std::vector<std::vector<int>>(8, stand);
  for (int i = 0; i < 8; ++i) {
    t.entries["walk"].push_back(i % 2 ? codes(step) : mirror_posecodes(codes(step)));
    t.entries["kick"].push_back(i >= 3 && i <= 5 ? codes(kick) : stand);
    t.entries["wave-left-hand"].push_back(i % 2 ? codes(wave) : stand);
    t.entries["wave-right-hand"].push_back(mirror_posecodes(i % 2 ? codes(wave) : stand));
    t.entries["walk|tired"].push_back(codes(bent));
    t.entries["guide"].push_back(codes(wave));  // its templates share only function words ("of") with the prompt below
  }
  return t;
}

TEST(Planner, SplitsClausesAtThen) {
  EXPECT_EQ(split_clauses("a person walks forward, then waves the right hand"),
            (std::vector<Words>{{"a", "person", "walks", "forward"}, {"waves", "the", "right", "hand"}}));
  EXPECT_EQ(split_clauses("kicks and then bows. after that dances, finally runs"),
            (std::vector<Words>{{"kicks"}, {"bows", "."}, {"dances"}, {"runs"}}));
  EXPECT_EQ(split_clauses(""), (std::vector<Words>{{}}));
  EXPECT_EQ(split_clauses("then then"), (std::vector<Words>{{}}));
}

TEST(Planner, MatchesContentAndSplitsKeyFrames) {
  const PlannerTable t = toy_table();
  const Plan p = plan_postures(t, "a person walks forward, then waves the right hand");
  ASSERT_EQ(p.clauses.size(), 2u);
  EXPECT_EQ(p.clauses[0].content, "walk");
  EXPECT_EQ(p.clauses[1].content, "wave-right-hand");
  EXPECT_EQ(p.clauses[0].frames, 4);
  EXPECT_EQ(p.clauses[1].frames, 4);
  ASSERT_EQ(p.scripts.size(), 8u);
  const std::vector<int> idx = key_frame_indices(8, 4);  // 0, 2, 5, 7
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(p.codes[i], t.at("walk")[idx[i]]);
    EXPECT_EQ(p.codes[4 + i], t.at("wave-right-hand")[idx[i]]);
    EXPECT_EQ(p.scripts[4 + i], posture_script(p.codes[4 + i]));
  }
  // Deterministic.
  const Plan q = plan_postures(t, "a person walks forward, then waves the right hand");
  EXPECT_EQ(p.scripts, q.scripts);
  // Three clauses over 8 key frames: 3, 3, 2; more clauses than frames keep the first k.
  const Plan r = plan_postures(t, "walks then kicks then waves the left hand");
  ASSERT_EQ(r.clauses.size(), 3u);
  EXPECT_EQ(r.clauses[0].frames + r.clauses[1].frames + r.clauses[2].frames, 8);
  EXPECT_EQ(r.clauses[2].frames, 2);
  EXPECT_EQ(plan_postures(t, "walks then kicks then walks", 2).scripts.size(), 2u);
}

TEST(Planner, StyleEntryAndUnknownWords) {
  const PlannerTable t = toy_table();
  const Plan tired = plan_postures(t, "a tired person walks forward");
  EXPECT_EQ(tired.clauses[0].style, "tired");
  EXPECT_EQ(tired.clauses[0].entry, "walk|tired");
  EXPECT_EQ(plan_postures(t, "an angry person walks forward").clauses[0].entry, "walk");  // no such entry
  const Plan unk = plan_postures(t, "experiencing a profound sense of joy");
  EXPECT_EQ(unk.clauses[0].content, "");
  EXPECT_EQ(unk.clauses[0].score, 0.0);
  for (const auto& s : unk.scripts) EXPECT_EQ(s, posture_script(t.at("").front()));
}

TEST(Planner, LeftRightModifierMirrorsUnsidedTemplates) {
  const PlannerTable t = toy_table();
  const Plan right = plan_postures(t, "a person kicks with the right leg");
  EXPECT_EQ(right.clauses[0].content, "kick");
  EXPECT_FALSE(right.clauses[0].mirrored);
  const Plan left = plan_postures(t, "a person kicks with the left leg");
  EXPECT_TRUE(left.clauses[0].mirrored);
  EXPECT_EQ(left.codes[4], mirror_posecodes(t.at("kick")[4]));
  EXPECT_NE(left.scripts[4].find("the left foot is off the ground"), std::string::npos) << left.scripts[4];
  EXPECT_THROW(plan_postures(t, "walks", 0), Error);
}

TEST(PlannerTable, MinedFromClipsWithMirroredLabels) {
  std::vector<data::MotionClip> clips(2);
  clips[0].name = "a", clips[0].content = "wave-left-hand", clips[0].style = "happy";
  clips[1].name = "b", clips[1].content = "walk", clips[1].style = "normal";
  for (auto& c : clips) {
    c.features = data::motion_to_features(t2m::testing::synthetic_walk(30));
    c.frames = 30;
  }
  const PostureScriptSet s = build_posture_script_set(clips, 8, true);
  EXPECT_EQ(s.size(), 32);
  const PlannerTable t = mine_planner_table(s, clips);
  for (const char* e : {"", "walk", "walk|normal", "wave-left-hand", "wave-right-hand|happy"})
    EXPECT_TRUE(t.has(e)) << e;
  EXPECT_EQ(t.at("wave-left-hand")[3], s.codes_of(3));  // one clip per entry: its own key pose
  EXPECT_EQ(t.at("wave-right-hand")[3], s.codes_of(8 + 3));
  EXPECT_EQ(mirror_content_label("walk-turn-left"), "walk-turn-right");
  // File round trip and bad files.
  const auto dir = std::filesystem::temp_directory_path() / ("t2m_planner_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  save_planner_table(t, (dir / "t.json").string());
  const PlannerTable r = load_planner_table((dir / "t.json").string());
  EXPECT_EQ(r.entries, t.entries);
  EXPECT_EQ(r.k, 8);
  std::ofstream(dir / "bad.json") << "{\"format\": \"t2m-promotion-planner-1\", \"k\": 8, \"rules\": [\"x\"]}";
  EXPECT_THROW(load_planner_table((dir / "bad.json").string()), Error);
  std::ofstream(dir / "junk.json") << "{not json";
  EXPECT_THROW(load_planner_table((dir / "junk.json").string()), Error);
  EXPECT_THROW(load_planner_table((dir / "missing.json").string()), Error);
  std::filesystem::remove_all(dir);
  EXPECT_THROW(mine_planner_table(PostureScriptSet{}, clips), Error);
}

}  // namespace
