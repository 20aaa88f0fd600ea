// planner.h — our motion planner for the PRO-Motion baseline (paper Sec 3.2): text -> posture scripts for K key
// frames. The paper prompts GPT-3.5 with the five posecode rules and PoseScript examples; no LLM is available
// offline, so this planner is a rule/template planner over our caption vocabulary (docs/CAPTIONS.md) and a
// template table mined from the train split (planner_table.h). It can only plan motions our data set contains
// (24 content labels, 220 content-style pairs in the shipped table); open-world prompts ("experiencing a profound sense of joy") fall back to the
// closest content by shared words or to the neutral (standing) pose.
//
// Steps (deterministic, no randomness):
//   1. clauses: the prompt's words (text::split_words) split at "then" (a preceding "," or "and" is dropped) and at
//      "after that" / "afterwards" / "finally"; empty clauses are dropped; no clause -> one empty clause.
//   2. content of a clause: cosine similarity between the clause's word set (subject and function words "a an the
//      person someone human man woman is of to with in on at for and by into it this them as who being" removed) and each content's tf-idf vector over the words of its caption templates
//      (idf = ln(1 + C / df) over the C contents); the best content wins (ties: caption table order); similarity
//      0 (no shared word) -> the neutral entry. style: the style whose subject/adverb words share the most words
//      with the clause (ties: table order; none -> no style).
//   3. direction / body-part modifier: when the clause says "left" xor "right" and the chosen content has no side in
//      its label, the template is mirrored (mirror_posecodes) if its active side (rules that differ from the neutral
//      pose, left minus right) is the other one.
//   4. key frames: K split over the n clauses as evenly as possible (first clauses get the remainder; n > K keeps
//      the first K clauses, one frame each); a clause with K_i frames takes the entry's codes at
//      key_frame_indices(table.k, K_i) (pose.h), from "<content>|<style>" when the table has it, else "<content>".
//   5. scripts: posture_script(codes) per key frame.
// Errors: t2m::Error for k < 1.
#pragma once
#include <string>
#include <vector>

#include "models/promotion/planner_table.h"

namespace t2m::promotion {

struct PlannedClause {
  std::string text;       // the clause's words joined
  std::string content;    // chosen content label ("" = neutral)
  std::string style;      // chosen style label ("" = none)
  std::string entry;      // the table entry used
  bool mirrored = false;  // step 3 applied
  int frames = 0;         // key frames given to the clause
  double score = 0;       // content similarity
};

struct Plan {
  std::vector<std::string> scripts;      // [K]
  std::vector<std::vector<int>> codes;   // [K][num_posecodes()]
  std::vector<PlannedClause> clauses;
};

// The prompt's clauses (step 1), each as its list of words.
std::vector<std::vector<std::string>> split_clauses(const std::string& prompt);

Plan plan_postures(const PlannerTable& table, const std::string& prompt, int k = 8);

}  // namespace t2m::promotion
