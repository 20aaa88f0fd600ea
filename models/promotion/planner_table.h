// planner_table.h — the data-driven template table of our rule/template motion planner (planner.h): for every
// content label, and every (content, style) pair of the data, K posecode vectors, one per key frame, mined from the
// captioned key poses of the TRAIN split (posture_script_set.h; PRO-Motion asks an LLM for these, we have none).
//
// Mining: items of the set (clip key poses and their mirrors) are grouped by entry and key index i; a mirrored
// item counts for the left/right-swapped content label ("wave-left-hand" <-> "wave-right-hand"; "walk" stays
// "walk"). The entry's codes at key i are those of the group's most typical item: the item maximising
// sum_r freq_r(its category of rule r) (freq over the group; ties: the first item), i.e. a real key pose's codes,
// never a mix of several poses. Entries: "<content>" and "<content>|<style>"; the entry "" (neutral) is the most
// typical item over all items and keys (a standing pose on this data).
// File (JSON, "format": "t2m-promotion-planner-1"): k, the rule names (checked on load against posecode_rules()),
// entries {name: [[codes of key 0], ...]} and "source" (free JSON).
// Errors (t2m::Error): empty set, clip indices outside the clip list, k mismatch; on load: missing file, bad JSON,
// another format, rule names that differ from the current table (a stale file).
#pragma once
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/data/loader.h"
#include "models/promotion/posture_script_set.h"

namespace t2m::promotion {

struct PlannerTable {
  int k = 0;
  std::map<std::string, std::vector<std::vector<int>>> entries;  // name -> [k][num_posecodes()]
  nlohmann::json source = nlohmann::json::object();
  bool has(const std::string& name) const { return entries.count(name) != 0; }
  const std::vector<std::vector<int>>& at(const std::string& name) const;  // throws when absent
};

// "wave-left-hand" <-> "wave-right-hand" (every "left" / "right" inside the label swapped).
std::string mirror_content_label(const std::string& label);

PlannerTable mine_planner_table(const PostureScriptSet& set, const std::vector<data::MotionClip>& clips);

void save_planner_table(const PlannerTable& t, const std::string& path);
PlannerTable load_planner_table(const std::string& path);

}  // namespace t2m::promotion
