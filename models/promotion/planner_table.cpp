// planner_table.cpp — mining the per-content key-pose code table from a posture-script set; JSON I/O.
#include "models/promotion/planner_table.h"

#include <fstream>
#include <sstream>

#include "models/promotion/posecodes.h"
#include "nn/checkpoint.h"
#include "tensor/tensor.h"

namespace t2m::promotion {

const std::vector<std::vector<int>>& PlannerTable::at(const std::string& name) const {
  auto it = entries.find(name);
  if (it == entries.end()) throw Error("PlannerTable: no entry '" + name + "'");
  return it->second;
}

std::string mirror_content_label(const std::string& label) {
  std::string out;
  for (size_t i = 0; i < label.size();) {
    if (label.compare(i, 4, "left") == 0) {
      out += "right";
      i += 4;
    } else if (label.compare(i, 5, "right") == 0) {
      out += "left";
      i += 5;
    } else {
      out += label[i++];
    }
  }
  return out;
}

namespace {

// Codes of the group's most typical item (see the header).
std::vector<int> typical_codes(const PostureScriptSet& s, const std::vector<int>& items) {
  const auto& rules = posecode_rules();
  const int R = (int)rules.size();
  std::vector<std::vector<int>> count(R);
  for (int r = 0; r < R; ++r) count[r].assign(rules[r].categories.size(), 0);
  for (int i : items)
    for (int r = 0; r < R; ++r) ++count[r][s.codes[(size_t)i * R + r]];
  int best = items.front();
  long best_score = -1;
  for (int i : items) {
    long sc = 0;
    for (int r = 0; r < R; ++r) sc += count[r][s.codes[(size_t)i * R + r]];
    if (sc > best_score) best_score = sc, best = i;
  }
  return s.codes_of(best);
}

}  // namespace

PlannerTable mine_planner_table(const PostureScriptSet& s, const std::vector<data::MotionClip>& clips) {
  if (s.size() == 0 || s.k < 1) throw Error("mine_planner_table: the posture-script set is empty");
  std::map<std::string, std::vector<std::vector<int>>> groups;  // entry -> [k] item lists
  std::vector<int> all;
  for (int i = 0; i < s.size(); ++i) {
    if (s.clip[i] < 0 || s.clip[i] >= (int)clips.size())
      throw Error("mine_planner_table: item " + std::to_string(i) + " refers to clip " + std::to_string(s.clip[i]) +
                  " of " + std::to_string(clips.size()));
    const data::MotionClip& c = clips[s.clip[i]];
    const std::string content = s.mirrored[i] ? mirror_content_label(c.content) : c.content;
    for (const std::string& e : {content, content + "|" + c.style}) {
      auto& g = groups[e];
      if (g.empty()) g.resize(s.k);
      g[s.key[i]].push_back(i);
    }
    all.push_back(i);
  }
  PlannerTable t;
  t.k = s.k;
  for (const auto& [name, keys] : groups) {
    std::vector<std::vector<int>> codes;
    for (const auto& items : keys) {
      if (items.empty()) throw Error("mine_planner_table: entry '" + name + "' has an empty key group");
      codes.push_back(typical_codes(s, items));
    }
    t.entries[name] = codes;
  }
  t.entries[""] = std::vector<std::vector<int>>(s.k, typical_codes(s, all));
  t.source = {{"items", s.size()}, {"clips", clips.size()}};
  return t;
}

void save_planner_table(const PlannerTable& t, const std::string& path) {
  nlohmann::json rules = nlohmann::json::array();
  for (const auto& r : posecode_rules()) rules.push_back(std::string(posecode_family_name(r.family)) + ":" + r.name);
  nlohmann::json j = {{"format", "t2m-promotion-planner-1"}, {"k", t.k}, {"rules", rules},
                      {"entries", t.entries}, {"source", t.source}};
  nn::write_file_atomic(path, j.dump() + "\n");
}

PlannerTable load_planner_table(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw Error("load_planner_table: cannot read " + path);
  std::stringstream ss;
  ss << f.rdbuf();
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(ss.str());
  } catch (const std::exception& e) {
    throw Error("load_planner_table: " + path + ": bad JSON (" + e.what() + ")");
  }
  if (!j.is_object() || j.value("format", "") != "t2m-promotion-planner-1")
    throw Error("load_planner_table: " + path + " is not a t2m-promotion-planner-1 file");
  nlohmann::json rules = nlohmann::json::array();
  for (const auto& r : posecode_rules()) rules.push_back(std::string(posecode_family_name(r.family)) + ":" + r.name);
  if (j["rules"] != rules)
    throw Error("load_planner_table: " + path + " was made for another posecode table (stale file: rebuild it)");
  PlannerTable t;
  try {
    t.k = j.at("k").get<int>();
    t.entries = j.at("entries").get<std::map<std::string, std::vector<std::vector<int>>>>();
    t.source = j.value("source", nlohmann::json::object());
  } catch (const std::exception& e) {
    throw Error("load_planner_table: " + path + ": bad entries (" + e.what() + ")");
  }
  const auto& pr = posecode_rules();
  for (const auto& [name, keys] : t.entries) {
    bool ok = (int)keys.size() == t.k;
    for (const auto& c : keys) {
      ok = ok && c.size() == pr.size();
      for (size_t r = 0; ok && r < c.size(); ++r) ok = c[r] >= 0 && c[r] < (int)pr[r].categories.size();
    }
    if (!ok) throw Error("load_planner_table: " + path + ": entry '" + name + "' has the wrong shape or categories");
  }
  if (t.k < 1 || !t.has("")) throw Error("load_planner_table: " + path + " has no neutral entry or k < 1");
  return t;
}

}  // namespace t2m::promotion
