// splits.h — train / val / test assignment of motion clips, by take, deterministic and stable.
//
// A clip name is "dataset-N_<content>_<style>_<take>" (Bandai naming; content and style use '-' never '_').
// Clips are grouped by (dataset, content, style). Every clip gets a key u in [0, 1) that is a pure function of its
// own name: u = frac(hash(group) + take * 0.618034...) (a Weyl sequence over the take number, offset by the
// FNV-1a/splitmix64 hash of the group), or hash(name) when the take is not a number. Consecutive takes spread
// evenly over [0, 1), so per-pair proportions stay close to 80/10/10; the assignment never depends on RNG order
// or input order.
//
// Rule (documented in docs/CAPTIONS.md, section "Splits"):
//   - groups with >= kSplitLargeGroup takes (all of dataset-2): by the clip's own key only,
//       u < 0.8 -> train, 0.8 <= u < 0.9 -> val, u >= 0.9 -> test.
//     Adding or removing a clip never moves any other clip of such a group.
//   - smaller groups (dataset-1, mostly 1 take per pair): takes ranked by key, largest first;
//       1 take -> train; 2 takes -> largest key test, other train;
//       3..kSplitLargeGroup-1 takes -> largest key test, second largest val, the rest train.
//     Adding a clip can only move clips of its own small group (and only when its key ranks in the top two).
// Errors: names that do not parse (fewer than 4 '_'-separated fields, empty field) and duplicate names throw
// t2m::Error naming the clip.
#pragma once
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace t2m::data {

inline constexpr int kSplitLargeGroup = 10;

enum class Split : uint8_t { train, val, test };
const char* split_name(Split s);                 // "train", "val", "test"
Split split_from_name(const std::string& s);     // inverse; throws t2m::Error on other strings

// The parts of a clip name. take keeps its leading zeros ("001").
struct ClipName {
  std::string dataset, content, style, take;
};
ClipName clip_name_parts(const std::string& name);   // throws t2m::Error
std::string clip_group(const ClipName& c);           // "dataset-N_<content>_<style>"

// The clip's split key in [0, 1): a pure function of the name. Throws t2m::Error when the name does not parse.
double split_key(const std::string& name);

// Assignment for a set of clip names (any order; result keyed and sorted by name).
std::map<std::string, Split> assign_splits(const std::vector<std::string>& names);

// JSON file: {"format": "t2m-splits-1", "rule": "...", "counts": {...}, "clips": {"name": "train", ...}}.
// Keys sorted, 1 space indent: the same assignment gives a byte-identical file.
std::string splits_to_json(const std::map<std::string, Split>& splits);
std::map<std::string, Split> splits_from_json(const std::string& text);  // throws t2m::Error on bad content
void save_splits(const std::map<std::string, Split>& splits, const std::string& path);  // throws on I/O error
std::map<std::string, Split> load_splits(const std::string& path);                       // throws on I/O error

// Names of the clips in one split, sorted.
std::vector<std::string> clips_in(const std::map<std::string, Split>& splits, Split s);

}  // namespace t2m::data
