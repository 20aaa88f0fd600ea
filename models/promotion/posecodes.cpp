// posecodes.cpp — the posecode rule table and its evaluation on joint positions (see posecodes.h).
#include "models/promotion/posecodes.h"

#include <algorithm>
#include <cmath>

#include "models/promotion/pose.h"
#include "sim/skeleton.h"
#include "tensor/tensor.h"

namespace t2m::promotion {

namespace {

using F = PosecodeFamily;

const std::vector<double> kAngleThresholds = {45, 75, 105, 135, 160};  // PoseScript
const std::vector<std::string> kAngleWords = {"completely bent", "almost completely bent", "bent at a right angle",
                                              "partially bent", "slightly bent", "straight"};
const std::vector<double> kDistThresholds = {0.20, 0.40, 0.80};        // PoseScript
const std::vector<double> kRelThresholds = {-0.15, 0.15};              // PoseScript
const std::vector<double> kOrientThresholds = {25, 65};                // ours

struct Table {
  std::vector<PosecodeRule> rules;

  // Adds a left rule and its mirror (L/R joints and words swapped); returns the left index.
  void add_pair(PosecodeRule left, PosecodeRule right) {
    int i = (int)rules.size();
    left.partner = i + 1;
    right.partner = i;
    rules.push_back(std::move(left));
    rules.push_back(std::move(right));
  }
  void add(PosecodeRule r) { rules.push_back(std::move(r)); }
};

PosecodeRule rule(F f, std::string name, int a, int b, int c, int axis, std::vector<double> th,
                  std::vector<std::string> cats, std::string text, std::string both = "") {
  PosecodeRule r;
  r.family = f;
  r.name = std::move(name);
  r.a = a;
  r.b = b;
  r.c = c;
  r.axis = axis;
  r.thresholds = std::move(th);
  r.categories = std::move(cats);
  r.text = std::move(text);
  r.both_text = std::move(both);
  return r;
}

// Left/right versions of a rule written with the word "{side}" and "{other}" (the opposite side).
std::string sided(std::string s, const char* side, const char* other) {
  for (auto [key, val] : {std::pair<const char*, const char*>{"{side}", side}, {"{other}", other}}) {
    size_t p;
    while ((p = s.find(key)) != std::string::npos) s.replace(p, std::string(key).size(), val);
  }
  return s;
}

Table build_table() {
  using namespace sim;
  Table t;
  auto pair = [&](F f, const std::string& name, int aL, int bL, int cL, int aR, int bR, int cR, int axis,
                  const std::vector<double>& th, const std::vector<std::string>& cats, const std::string& text,
                  const std::string& both) {
    t.add_pair(rule(f, sided(name, "left", "right"), aL, bL, cL, axis, th, cats, sided(text, "left", "right"), both),
               rule(f, sided(name, "right", "left"), aR, bR, cR, axis, th, cats, sided(text, "right", "left"), both));
  };
  // 1. bending (elbows, knees)
  pair(F::bending, "{side} elbow", kUpperArmL, kLowerArmL, kHandL, kUpperArmR, kLowerArmR, kHandR, -1,
       kAngleThresholds, kAngleWords, "the {side} elbow is {c}", "both elbows are {c}");
  pair(F::bending, "{side} knee", kUpperLegL, kLowerLegL, kFootL, kUpperLegR, kLowerLegR, kFootR, -1,
       kAngleThresholds, kAngleWords, "the {side} knee is {c}", "both knees are {c}");
  // 5. ground contact (feet: a = ankle, b = toes; knees)
  pair(F::ground_contact, "{side} foot", kFootL, kToesL, -1, kFootR, kToesR, -1, -1, {0.06, 0.15},
       {"on the ground", "", "off the ground"}, "the {side} foot is {c}", "both feet are {c}");
  pair(F::ground_contact, "{side} knee", kLowerLegL, -1, -1, kLowerLegR, -1, -1, -1, {0.15},
       {"on the ground", ""}, "the {side} knee is {c}", "both knees are {c}");
  // 3. relative positions
  pair(F::relative_position, "{side} hand / head (z)", kHandL, kHead, -1, kHandR, kHead, -1, 2, kRelThresholds,
       {"", "", "above"}, "the {side} hand is {c} the head", "both hands are {c} the head");
  pair(F::relative_position, "{side} hand / {side} shoulder (z)", kHandL, kUpperArmL, -1, kHandR, kUpperArmR, -1,
       2, kRelThresholds, {"", "", "above"}, "the {side} hand is {c} the {side} shoulder",
       "both hands are {c} the shoulders");
  pair(F::relative_position, "{side} hand / torso (x)", kHandL, kSpine, -1, kHandR, kSpine, -1, 0,
       {-0.15, 0.25}, {"behind", "", "in front of"}, "the {side} hand is {c} the torso",
       "both hands are {c} the torso");
  pair(F::relative_position, "{side} knee / {side} hip (z)", kLowerLegL, kUpperLegL, -1, kLowerLegR, kUpperLegR,
       -1, 2, {-0.15, -0.05}, {"", "", "as high as"}, "the {side} knee is {c} the {side} hip",
       "both knees are {c} the hips");
  t.add(rule(F::relative_position, "left foot / right foot (x)", kFootL, kFootR, -1, 0, kRelThresholds,
             {"behind", "", "in front of"}, "the left foot is {c} the right foot"));
  t.rules.back().mirror_flips = true;
  t.add(rule(F::relative_position, "left foot / right foot (z)", kFootL, kFootR, -1, 2, kRelThresholds,
             {"below", "", "above"}, "the left foot is {c} the right foot"));
  t.rules.back().mirror_flips = true;
  t.add(rule(F::relative_position, "left hand / right hand (y)", kHandL, kHandR, -1, 1, {-0.05},
             {"to the right of", ""}, "the left hand is {c} the right hand"));
  t.add(rule(F::relative_position, "left foot / right foot (y)", kFootL, kFootR, -1, 1, {-0.05},
             {"to the right of", ""}, "the left foot is {c} the right foot"));
  t.add(rule(F::relative_position, "torso / hips (x)", kNeck, kHips, -1, 0, {-0.15, 0.20},
             {"behind", "", "in front of"}, "the neck is {c} the hips"));
  // 2. distances
  t.add(rule(F::distance, "hands", kHandL, kHandR, -1, -1, kDistThresholds,
             {"close together", "shoulder width apart", "spread apart", "wide apart"}, "the hands are {c}"));
  t.add(rule(F::distance, "feet", kFootL, kFootR, -1, -1, kDistThresholds,
             {"close together", "shoulder width apart", "spread apart", "wide apart"}, "the feet are {c}"));
  t.add(rule(F::distance, "knees", kLowerLegL, kLowerLegR, -1, -1, kDistThresholds,
             {"close together", "", "", "wide apart"}, "the knees are {c}"));
  t.add(rule(F::distance, "elbows", kLowerArmL, kLowerArmR, -1, -1, {0.20, 0.40, 0.80, 1.0},
             {"close together", "", "", "wide apart", "very wide apart"}, "the elbows are {c}"));
  pair(F::distance, "{side} hand / {other} shoulder", kHandL, kUpperArmR, -1, kHandR, kUpperArmL, -1, -1,
       kDistThresholds, {"close to", "", "", ""}, "the {side} hand is {c} the {other} shoulder",
       "each hand is {c} the other shoulder");
  pair(F::distance, "{side} hand / head", kHandL, kHead, -1, kHandR, kHead, -1, -1, kDistThresholds,
       {"close to", "", "", ""}, "the {side} hand is {c} the head", "both hands are {c} the head");
  pair(F::distance, "{side} hand / {side} foot", kHandL, kFootL, -1, kHandR, kFootR, -1, -1, {0.30},
       {"close to", ""}, "the {side} hand is {c} the {side} foot", "both hands are {c} the feet");
  // 4. orientation (limb b - a against the vertical)
  const std::vector<std::string> orient = {"vertical", "", "horizontal"};
  pair(F::orientation, "{side} thigh", kUpperLegL, kLowerLegL, -1, kUpperLegR, kLowerLegR, -1, -1,
       kOrientThresholds, orient, "the {side} thigh is {c}", "both thighs are {c}");
  pair(F::orientation, "{side} shin", kLowerLegL, kFootL, -1, kLowerLegR, kFootR, -1, -1, kOrientThresholds,
       orient, "the {side} shin is {c}", "both shins are {c}");
  pair(F::orientation, "{side} upper arm", kUpperArmL, kLowerArmL, -1, kUpperArmR, kLowerArmR, -1, -1,
       kOrientThresholds, orient, "the {side} upper arm is {c}", "both upper arms are {c}");
  pair(F::orientation, "{side} forearm", kLowerArmL, kHandL, -1, kLowerArmR, kHandR, -1, -1, kOrientThresholds,
       orient, "the {side} forearm is {c}", "both forearms are {c}");
  t.add(rule(F::orientation, "torso", kHips, kNeck, -1, -1, kOrientThresholds, orient, "the torso is {c}"));
  return t;
}

}  // namespace

const char* posecode_family_name(PosecodeFamily f) {
  switch (f) {
    case F::bending: return "bending";
    case F::distance: return "distance";
    case F::relative_position: return "relative_position";
    case F::orientation: return "orientation";
    case F::ground_contact: return "ground_contact";
  }
  return "?";
}

const std::vector<PosecodeRule>& posecode_rules() {
  static const Table t = build_table();
  return t.rules;
}

int num_posecodes() { return (int)posecode_rules().size(); }

double posecode_value(const PosecodeRule& r, const float* j) {
  auto p = [&](int k, int d) { return (double)j[3 * k + d]; };
  switch (r.family) {
    case F::bending: {  // PRO-Motion rule 1: angle at b
      double u[3], v[3], uu = 0, vv = 0, uv = 0;
      for (int d = 0; d < 3; ++d) {
        u[d] = p(r.a, d) - p(r.b, d);
        v[d] = p(r.c, d) - p(r.b, d);
        uu += u[d] * u[d];
        vv += v[d] * v[d];
        uv += u[d] * v[d];
      }
      double den = std::sqrt(uu * vv);
      if (den < 1e-12) return 180.0;
      return std::acos(std::clamp(uv / den, -1.0, 1.0)) * 180.0 / M_PI;
    }
    case F::distance: {  // rule 2
      double s = 0;
      for (int d = 0; d < 3; ++d) s += (p(r.a, d) - p(r.b, d)) * (p(r.a, d) - p(r.b, d));
      return std::sqrt(s);
    }
    case F::relative_position:  // rule 3
      return p(r.a, r.axis) - p(r.b, r.axis);
    case F::orientation: {  // rule 4: angle to the vertical in [0, 90]
      double v[3], n = 0;
      for (int d = 0; d < 3; ++d) {
        v[d] = p(r.b, d) - p(r.a, d);
        n += v[d] * v[d];
      }
      if (n < 1e-12) return 45.0;
      return std::acos(std::min(1.0, std::fabs(v[2]) / std::sqrt(n))) * 180.0 / M_PI;
    }
    case F::ground_contact:  // rule 5: height of the lowest of the listed joints
      return r.b >= 0 ? std::min(p(r.a, 2), p(r.b, 2)) : p(r.a, 2);
  }
  return 0.0;
}

int posecode_category(const PosecodeRule& r, double value) {
  int c = 0;
  for (double t : r.thresholds)
    if (value >= t) ++c;
  return c;
}

std::vector<int> compute_posecodes(const float* joints) {
  const auto& rules = posecode_rules();
  std::vector<int> out(rules.size());
  for (size_t i = 0; i < rules.size(); ++i) out[i] = posecode_category(rules[i], posecode_value(rules[i], joints));
  return out;
}

std::vector<int> pose_posecodes(const float* pose) {
  std::vector<float> j = joint_positions(pose);
  return compute_posecodes(j.data());
}

std::vector<int> mirror_posecodes(const std::vector<int>& codes) {
  const auto& rules = posecode_rules();
  if (codes.size() != rules.size())
    throw Error("mirror_posecodes: expected " + std::to_string(rules.size()) + " codes, got " +
                std::to_string(codes.size()));
  std::vector<int> out(codes.size());
  for (size_t i = 0; i < rules.size(); ++i) {
    const PosecodeRule& r = rules[i];
    if (r.partner >= 0)
      out[i] = codes[r.partner];
    else if (r.mirror_flips)
      out[i] = (int)r.categories.size() - 1 - codes[i];
    else
      out[i] = codes[i];
  }
  return out;
}

double posecode_agreement(const std::vector<int>& target, const std::vector<int>& got) {
  const auto& rules = posecode_rules();
  if (target.size() != rules.size() || got.size() != rules.size())
    throw Error("posecode_agreement: expected " + std::to_string(rules.size()) + " codes, got " +
                std::to_string(target.size()) + " and " + std::to_string(got.size()));
  int n = 0, hit = 0;
  for (size_t i = 0; i < rules.size(); ++i) {
    if (!rules[i].described(target[i])) continue;
    ++n;
    hit += got[i] == target[i];
  }
  return n == 0 ? 1.0 : (double)hit / n;
}

}  // namespace t2m::promotion
