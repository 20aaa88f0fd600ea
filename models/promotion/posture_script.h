// posture_script.h — PRO-Motion posture scripts: the text a set of posecodes produces (our PoseScript-style
// automatic captions; the planner writes the same language).
//
// Rendering (deterministic): rules in table order (posecodes.h: bending, ground contact, relative positions,
// distances, orientation); a rule whose category is not described is skipped; a left/right pair with the same
// described category is aggregated into the rule's both_text ("both knees are straight"); each clause is the
// rule's text with {c} replaced by the category phrase; clauses of one family are joined with ", " and end with
// ". ". Lower case, no leading subject. Nothing described: "the body is in a neutral pose."
// Example: "both elbows are slightly bent, both knees are straight. both feet are on the ground. the hands are
// spread apart, the feet are close together. the torso is vertical, both thighs are vertical."
// Errors: t2m::Error when the code vector does not have num_posecodes() entries or a category is out of range.
#pragma once
#include <string>
#include <vector>

namespace t2m::promotion {

// Categories [num_posecodes()] -> script text.
std::string posture_script(const std::vector<int>& codes);
// A pose [kPoseDim] -> its script (pose_posecodes + posture_script).
std::string pose_script(const float* pose);
// Every word the scripts can use (each rule's text and category phrases, aggregated forms, punctuation), as
// sentences for a tokenizer's corpus (text::Tokenizer::build).
std::vector<std::string> posture_script_corpus();

}  // namespace t2m::promotion
