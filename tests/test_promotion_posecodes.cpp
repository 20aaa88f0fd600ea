// test_promotion_posecodes.cpp — every posecode rule family on hand-made poses, the script text (aggregation,
// order), agreement, and bad input.
#include <gtest/gtest.h>

#include <map>

#include "models/data/features.h"
#include "models/promotion/pose.h"
#include "models/promotion/posecodes.h"
#include "models/promotion/posture_script.h"
#include "sim/skeleton.h"
#include "tensor/tensor.h"
#include "test_features_synthetic.h"
#include "test_promotion_poses.h"

namespace {

using namespace t2m;
using namespace t2m::promotion;
using namespace t2m::sim;
using t2m::testing::Joints;
using t2m::testing::standing;

int rule_index(const std::string& name) {
  const auto& r = posecode_rules();
  for (size_t i = 0; i < r.size(); ++i)
    if (r[i].name == name) return (int)i;
  ADD_FAILURE() << "no rule " << name;
  return 0;
}

std::string category(const Joints& J, const std::string& name) {
  int i = rule_index(name);
  std::vector<int> c = compute_posecodes(J.data());
  const PosecodeRule& r = posecode_rules()[i];
  return r.described(c[i]) ? r.categories[c[i]] : "(not described)";
}

TEST(Posecodes, TableIsConsistent) {
  const auto& rules = posecode_rules();
  std::map<PosecodeFamily, int> per_family;
  for (size_t i = 0; i < rules.size(); ++i) {
    const PosecodeRule& r = rules[i];
    EXPECT_EQ(r.thresholds.size() + 1, r.categories.size()) << r.name;
    for (size_t k = 1; k < r.thresholds.size(); ++k) EXPECT_LT(r.thresholds[k - 1], r.thresholds[k]) << r.name;
    EXPECT_NE(r.text.find("{c}"), std::string::npos) << r.name;
    if (r.partner >= 0) {
      EXPECT_EQ(rules[r.partner].partner, (int)i) << r.name;
    }
    ++per_family[r.family];
  }
  EXPECT_EQ(per_family.size(), (size_t)kNumPosecodeFamilies);
}

TEST(Posecodes, BendingOfElbowsAndKnees) {
  Joints J = standing();
  EXPECT_EQ(category(J, "left elbow"), "straight");
  EXPECT_EQ(category(J, "left knee"), "straight");
  J.set(kHandL, 0.27f, 0.18f, 1.12f);  // forearm forward: 90 degrees
  EXPECT_EQ(category(J, "left elbow"), "bent at a right angle");
  J.set(kHandL, 0.05f, 0.18f, 1.38f);  // folded up to the shoulder
  EXPECT_EQ(category(J, "left elbow"), "completely bent");
  EXPECT_EQ(category(J, "right elbow"), "straight");
  J.set(kFootR, -0.25f, -0.10f, 0.30f);  // shin backwards ~ 53 degrees off the thigh
  EXPECT_EQ(category(J, "right knee"), "partially bent");
  EXPECT_NEAR(posecode_value(posecode_rules()[rule_index("left knee")], standing().data()), 180.0, 1e-3);
}

TEST(Posecodes, DistancesBetweenBodyParts) {
  Joints J = standing();
  EXPECT_EQ(category(J, "hands"), "shoulder width apart");  // 0.36 m
  EXPECT_EQ(category(J, "feet"), "shoulder width apart");   // 0.20 m: the threshold counts to the upper class
  J.set(kFootL, 0, 0.05f, 0.08f);
  EXPECT_EQ(category(J, "feet"), "close together");
  J.set(kHandL, 0.30f, 0.02f, 1.20f);
  J.set(kHandR, 0.30f, -0.02f, 1.20f);
  EXPECT_EQ(category(J, "hands"), "close together");
  J.set(kHandL, 0, 0.90f, 1.40f);
  J.set(kHandR, 0, -0.90f, 1.40f);
  EXPECT_EQ(category(J, "hands"), "wide apart");
  J = standing();
  J.set(kHandL, 0.05f, -0.15f, 1.40f);  // on the right shoulder
  EXPECT_EQ(category(J, "left hand / right shoulder"), "close to");
  EXPECT_EQ(category(J, "right hand / left shoulder"), "(not described)");
}

TEST(Posecodes, RelativePositions) {
  Joints J = standing();
  EXPECT_EQ(category(J, "left hand / head (z)"), "(not described)");
  J.set(kLowerArmL, 0, 0.18f, 1.68f);
  J.set(kHandL, 0, 0.18f, 1.95f);
  EXPECT_EQ(category(J, "left hand / head (z)"), "above");
  EXPECT_EQ(category(J, "left hand / left shoulder (z)"), "above");
  EXPECT_EQ(category(J, "right hand / head (z)"), "(not described)");
  J = standing();
  EXPECT_EQ(category(J, "left hand / right hand (y)"), "(not described)");
  J.set(kHandL, 0.3f, -0.10f, 1.2f);  // arms crossed
  J.set(kHandR, 0.3f, 0.10f, 1.2f);
  EXPECT_EQ(category(J, "left hand / right hand (y)"), "to the right of");
  J = standing();
  J.set(kFootL, 0.40f, 0.10f, 0.08f);  // step forward
  EXPECT_EQ(category(J, "left foot / right foot (x)"), "in front of");
  J.set(kFootL, -0.40f, 0.10f, 0.08f);
  EXPECT_EQ(category(J, "left foot / right foot (x)"), "behind");
}

TEST(Posecodes, OrientationOfLimbs) {
  Joints J = standing();
  EXPECT_EQ(category(J, "left upper arm"), "vertical");
  EXPECT_EQ(category(J, "torso"), "vertical");
  J.set(kLowerArmL, 0, 0.46f, 1.40f);  // T-pose arm
  J.set(kHandL, 0, 0.73f, 1.42f);
  EXPECT_EQ(category(J, "left upper arm"), "horizontal");
  EXPECT_EQ(category(J, "left forearm"), "horizontal");
  J.set(kHandL, 0, 0.65f, 1.70f);  // forearm at ~48 degrees: not described
  EXPECT_EQ(category(J, "left forearm"), "(not described)");
  J = standing();
  J.set(kLowerLegR, 0.42f, -0.10f, 0.92f);  // thigh raised forward
  EXPECT_EQ(category(J, "right thigh"), "horizontal");
  EXPECT_EQ(category(J, "right knee / right hip (z)"), "as high as");
}

TEST(Posecodes, GroundContact) {
  Joints J = standing();
  EXPECT_EQ(category(J, "left foot"), "on the ground");
  EXPECT_EQ(category(J, "left knee"), "straight");
  J.set(kFootL, 0.05f, 0.10f, 0.40f);
  J.set(kToesL, 0.17f, 0.10f, 0.36f);
  EXPECT_EQ(category(J, "left foot"), "off the ground");
  EXPECT_EQ(category(J, "right foot"), "on the ground");
  J = standing();
  J.set(kLowerLegL, 0.1f, 0.10f, 0.08f);  // kneeling
  int knee_contact = -1;
  const auto& rules = posecode_rules();
  for (size_t i = 0; i < rules.size(); ++i)
    if (rules[i].family == PosecodeFamily::ground_contact && rules[i].name == "left knee") knee_contact = (int)i;
  ASSERT_GE(knee_contact, 0);
  EXPECT_EQ(compute_posecodes(J.data())[knee_contact], 0);
  EXPECT_NE(compute_posecodes(standing().data())[knee_contact], 0);
}

TEST(PostureScript, TextAggregatesSymmetricCodes) {
  Joints J = standing();
  std::string s = posture_script(compute_posecodes(J.data()));
  EXPECT_NE(s.find("both elbows are straight, both knees are straight."), std::string::npos) << s;
  EXPECT_NE(s.find("both feet are on the ground."), std::string::npos) << s;
  EXPECT_NE(s.find("the torso is vertical"), std::string::npos) << s;
  EXPECT_EQ(s.find("left elbow"), std::string::npos) << s;
  J.set(kHandL, 0.05f, 0.18f, 1.38f);
  s = posture_script(compute_posecodes(J.data()));
  EXPECT_NE(s.find("the left elbow is completely bent, the right elbow is straight, both knees are straight."),
            std::string::npos)
      << s;
  EXPECT_EQ(s, posture_script(compute_posecodes(J.data())));  // deterministic
  // Every word of a script is in the corpus the tokenizer is built from.
  std::string corpus;
  for (const std::string& c : posture_script_corpus()) corpus += " " + c;
  for (size_t p = 0, q; p < s.size(); p = q + 1) {
    q = s.find_first_of(" ,.", p);
    if (q == std::string::npos) q = s.size();
    if (q > p) {
      EXPECT_NE(corpus.find(s.substr(p, q - p)), std::string::npos) << s.substr(p, q - p);
    }
  }
}

TEST(PostureScript, AgreementCountsDescribedCodes) {
  std::vector<int> a = compute_posecodes(standing().data());
  EXPECT_DOUBLE_EQ(posecode_agreement(a, a), 1.0);
  Joints J = standing();
  J.set(kHandL, 0.05f, 0.18f, 1.38f);
  std::vector<int> b = compute_posecodes(J.data());
  double ag = posecode_agreement(a, b);
  EXPECT_GT(ag, 0.5);
  EXPECT_LT(ag, 1.0);
}

TEST(PostureScript, BadInputThrows) {
  EXPECT_THROW(posture_script({1, 2, 3}), Error);
  std::vector<int> c(num_posecodes(), 0);
  c[0] = 99;
  EXPECT_THROW(posture_script(c), Error);
  EXPECT_THROW(posecode_agreement(c, {0}), Error);
}

}  // namespace

namespace {

TEST(Posecodes, MirrorOfCodesEqualsCodesOfTheMirroredPose) {
  using namespace t2m;
  using namespace t2m::promotion;
  const std::vector<float> f = data::motion_to_features(t2m::testing::synthetic_walk(40));
  const std::vector<float> p = poses_from_features(f), m = mirror_poses(p);
  for (int t = 0; t < 40; ++t)
    EXPECT_EQ(mirror_posecodes(pose_posecodes(p.data() + t * kPoseDim)), pose_posecodes(m.data() + t * kPoseDim))
        << t;
  Joints J = standing();
  J.set(kFootL, 0.40f, 0.10f, 0.30f);  // left foot forward and up
  J.set(kToesL, 0.52f, 0.10f, 0.26f);
  const std::vector<int> c = compute_posecodes(J.data()), mc = mirror_posecodes(c);
  const std::string s = posture_script(mc);
  EXPECT_NE(s.find("the right foot is off the ground"), std::string::npos) << s;
  EXPECT_NE(s.find("the left foot is behind the right foot"), std::string::npos) << s;
  EXPECT_THROW(mirror_posecodes({1}), Error);
}

}  // namespace
