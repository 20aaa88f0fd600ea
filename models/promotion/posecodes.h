// posecodes.h — PRO-Motion's five posture-script rule families (paper Sec 3.2 / appendix C, after PoseScript's
// posecodes) computed from the joint positions of one pose (pose.h joint_positions: [21, 3] metres, heading frame,
// x forward, y to the performer's left, z up, floor z = 0).
//
// Families and measured value (joints of sim/skeleton.h: UpperArm = shoulder, LowerArm = elbow, Hand = wrist,
// UpperLeg = hip, LowerLeg = knee, Foot = ankle):
//   bending            angle (degrees) at joint b between a - b and c - b: elbows, knees.
//                      completely bent < 45 <= almost completely bent < 75 <= bent at a right angle < 105 <=
//                      partially bent < 135 <= slightly bent < 160 <= straight   (PoseScript's thresholds)
//   distance           |p_a - p_b| (m): close < 0.20 <= shoulder width apart < 0.40 <= spread < 0.80 <= wide
//                      (PoseScript's thresholds); some pairs describe only "close".
//   relative_position  (p_a - p_b) along one body axis (m): x (behind / in front of), y (to the right of / to the
//                      left of), z (below / above); |difference| < 0.15 m (PoseScript) is not described, and the
//                      usual side of some pairs (left hand left of the right hand) is not described either.
//   orientation        angle between limb b - a and the vertical (degrees, 0..90): vertical < 25, horizontal > 65
//                      (our choice: PoseScript's values are not given in the PRO-Motion paper), between: not said.
//   ground_contact     feet: the lower of ankle and toes height (m) < 0.06 "on the ground", > 0.15 "off the
//                      ground"; knees: knee height < 0.15 m "on the ground" (our choices for the Bandai skeleton;
//                      docs/PROMOTION.md gives the statistics).
// A rule's category is an index into its categories; category_described tells whether scripts mention it.
// The rule table is fixed (posecode_rules()); `partner` is the left/right counterpart (-1 = none), used by the
// script to aggregate "both elbows are straight".
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace t2m::promotion {

enum class PosecodeFamily : uint8_t { bending, distance, relative_position, orientation, ground_contact };
inline constexpr int kNumPosecodeFamilies = 5;
const char* posecode_family_name(PosecodeFamily f);  // "bending", "distance", ...

struct PosecodeRule {
  PosecodeFamily family;
  std::string name;                     // "left elbow", "left hand / head (z)"
  int a = -1, b = -1, c = -1;           // joints (sim::JointId); c: bending only; b: contact uses b as a 2nd joint
  int axis = -1;                        // relative_position: 0 x, 1 y, 2 z
  std::vector<double> thresholds;       // increasing, categories.size() - 1 entries
  std::vector<std::string> categories;  // phrase per category, "" = not described
  std::string text;                     // "the left elbow is {c}"
  std::string both_text;                // "both elbows are {c}" (aggregation with the partner), "" = none
  int partner = -1;                     // index of the left/right counterpart rule
  bool mirror_flips = false;            // L/R joint pair along x or z: the mirror reverses the category order
  bool described(int category) const { return category >= 0 && !categories[category].empty(); }
};

const std::vector<PosecodeRule>& posecode_rules();
int num_posecodes();

// The measured value of one rule on joints [21, 3] (degrees or metres, see above).
double posecode_value(const PosecodeRule& r, const float* joints);
// Category of a value: the number of thresholds <= value.
int posecode_category(const PosecodeRule& r, double value);
// Categories of every rule for joints [21, 3] -> [num_posecodes()].
std::vector<int> compute_posecodes(const float* joints);
// Categories of a pose [kPoseDim] (pose.h).
std::vector<int> pose_posecodes(const float* pose);

// The codes of the left/right mirrored pose (features_mirror.h): partner rules swap their categories, rules with
// mirror_flips reverse theirs (c -> n - 1 - c; symmetric thresholds), the others keep theirs. Exact except for values
// lying exactly on a threshold. Throws when the size is not num_posecodes().
std::vector<int> mirror_posecodes(const std::vector<int>& codes);

// Agreement of `got` with the described codes of `target`: (codes described in target with got == target) /
// (codes described in target); 1 when target describes nothing. Sizes must be num_posecodes() (throws).
double posecode_agreement(const std::vector<int>& target, const std::vector<int>& got);

}  // namespace t2m::promotion
