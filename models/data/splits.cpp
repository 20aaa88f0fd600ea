// splits.cpp — hash keys, the large/small group rule, JSON I/O.
#include "models/data/splits.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <unistd.h>

#include "nn/fnv1a.h"
#include "tensor/tensor.h"

namespace t2m::data {

const char* split_name(Split s) {
  switch (s) {
    case Split::train: return "train";
    case Split::val: return "val";
    case Split::test: return "test";
  }
  return "?";
}

Split split_from_name(const std::string& s) {
  if (s == "train") return Split::train;
  if (s == "val") return Split::val;
  if (s == "test") return Split::test;
  throw Error("split_from_name: unknown split '" + s + "' (expected train, val or test)");
}

ClipName clip_name_parts(const std::string& name) {
  std::vector<std::string> parts;
  size_t start = 0;
  while (true) {
    size_t p = name.find('_', start);
    parts.push_back(name.substr(start, p == std::string::npos ? std::string::npos : p - start));
    if (p == std::string::npos) break;
    start = p + 1;
  }
  if (parts.size() != 4)
    throw Error("clip_name_parts: '" + name + "' has " + std::to_string(parts.size()) +
                " '_'-separated fields, expected 4 (dataset_content_style_take)");
  for (const auto& p : parts)
    if (p.empty()) throw Error("clip_name_parts: '" + name + "' has an empty field");
  return ClipName{parts[0], parts[1], parts[2], parts[3]};
}

std::string clip_group(const ClipName& c) { return c.dataset + "_" + c.content + "_" + c.style; }

namespace {

// FNV-1a 64 of a string, then the splitmix64 finaliser (spreads close strings apart); mapped to [0, 1).
double hash01(const std::string& s) {
  uint64_t h = nn::fnv1a64(s.data(), s.size());
  h += 0x9e3779b97f4a7c15ull;
  h = (h ^ (h >> 30)) * 0xbf58476d1ce4e5b9ull;
  h = (h ^ (h >> 27)) * 0x94d049bb133111ebull;
  h ^= h >> 31;
  return double(h >> 11) * 0x1.0p-53;
}

}  // namespace

double split_key(const std::string& name) {
  ClipName c = clip_name_parts(name);
  bool numeric = c.take.size() <= 9 && std::all_of(c.take.begin(), c.take.end(), [](char ch) {
    return ch >= '0' && ch <= '9';
  });
  if (!numeric) return hash01(name);
  // Weyl sequence over the take number, offset by the group hash: any run of consecutive takes of a group
  // covers [0, 1) almost evenly, so every pair gets close to 80/10/10 with a per-clip rule.
  double u = hash01(clip_group(c)) + std::stod(c.take) * 0.6180339887498949;
  return u - std::floor(u);
}

std::map<std::string, Split> assign_splits(const std::vector<std::string>& names) {
  std::map<std::string, std::vector<std::string>> groups;
  std::map<std::string, Split> out;
  for (const auto& n : names) {
    if (out.count(n)) throw Error("assign_splits: duplicate clip name '" + n + "'");
    out[n] = Split::train;
    groups[clip_group(clip_name_parts(n))].push_back(n);
  }
  for (auto& [g, members] : groups) {
    const int n = (int)members.size();
    if (n >= kSplitLargeGroup) {
      for (const auto& m : members) {
        double u = split_key(m);
        out[m] = u < 0.8 ? Split::train : (u < 0.9 ? Split::val : Split::test);
      }
      continue;
    }
    std::sort(members.begin(), members.end(), [](const std::string& a, const std::string& b) {
      double ka = split_key(a), kb = split_key(b);
      return ka != kb ? ka > kb : a < b;
    });
    if (n >= 2) out[members[0]] = Split::test;
    if (n >= 3) out[members[1]] = Split::val;
  }
  return out;
}

std::string splits_to_json(const std::map<std::string, Split>& splits) {
  nlohmann::ordered_json j;
  j["format"] = "t2m-splits-1";
  j["rule"] = "groups by dataset_content_style; key u = frac(hash(group) + take * 0.618034) (hash(name) if the take "
              "is not a number); >=10 takes: u < 0.8 train, < 0.9 val, else test; fewer: rank by u, 1 -> train, "
              "2 -> top test, 3..9 -> top test, second val, rest train";
  int c[3] = {0, 0, 0};
  for (const auto& kv : splits) c[(int)kv.second]++;
  j["counts"] = {{"train", c[0]}, {"val", c[1]}, {"test", c[2]}};
  nlohmann::ordered_json clips = nlohmann::ordered_json::object();
  for (const auto& [name, s] : splits) clips[name] = split_name(s);  // std::map: sorted by name
  j["clips"] = clips;
  return j.dump(1) + "\n";
}

std::map<std::string, Split> splits_from_json(const std::string& text) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const std::exception& e) {
    throw Error(std::string("splits_from_json: invalid JSON: ") + e.what());
  }
  if (!j.is_object() || j.value("format", "") != "t2m-splits-1" || !j.contains("clips") || !j["clips"].is_object())
    throw Error("splits_from_json: not a t2m-splits-1 file (need \"format\" and a \"clips\" object)");
  std::map<std::string, Split> out;
  for (auto it = j["clips"].begin(); it != j["clips"].end(); ++it) {
    if (!it.value().is_string())
      throw Error("splits_from_json: clip '" + it.key() + "' has a non-string split");
    out[it.key()] = split_from_name(it.value().get<std::string>());
  }
  return out;
}

void save_splits(const std::map<std::string, Split>& splits, const std::string& path) {
  std::string tmp = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream f(tmp, std::ios::binary);
    if (!f) throw Error("save_splits: cannot open '" + tmp + "' for writing");
    f << splits_to_json(splits);
    if (!f) throw Error("save_splits: write failed for '" + tmp + "'");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) throw Error("save_splits: cannot rename to '" + path + "'");
}

std::map<std::string, Split> load_splits(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error("load_splits: cannot open '" + path + "'");
  std::stringstream ss;
  ss << f.rdbuf();
  return splits_from_json(ss.str());
}

std::vector<std::string> clips_in(const std::map<std::string, Split>& splits, Split s) {
  std::vector<std::string> out;
  for (const auto& [n, v] : splits)
    if (v == s) out.push_back(n);
  return out;
}

}  // namespace t2m::data
