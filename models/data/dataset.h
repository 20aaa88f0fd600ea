// dataset.h — the Bandai-Namco-Research-Motiondataset on disk: unpack once into a cache, build a manifest.
//
// Layout after prepare_dataset(data_dir, cache_dir):
//   CACHE/bandai/Bandai-Namco-Research-Motiondataset-{1,2}/data/<name>.bvh, <name>.json   (from the archives)
//   CACHE/bandai/.unpacked-dataset-N       marker: written last, holds the archive size; present = unpack done
//   CACHE/bandai/manifest.json             the Manifest (see save_manifest)
// data_dir holds dataset-{1,2}.tar.zst and cfg/dataset-{1,2}_{content,style}_label.txt (line index = label id).
// <name> = dataset-N_<content>_<style>_<take>, e.g. dataset-2_walk_active_001; <name>.json = {"content": c,
// "style": s}. Unpacking uses libzstd (streaming) and a small ustar reader; each file is written atomically
// (temp + rename); entries with absolute paths or ".." are rejected. Errors: t2m::Error naming the archive/file.
#pragma once
#include <string>
#include <vector>

#include "sim/skeleton.h"

namespace t2m::data {

struct ClipInfo {
  std::string name;            // dataset-2_walk_active_001
  int dataset = 0;             // 1 or 2
  int content = -1;            // content label id (from <name>.json)
  int style = -1;              // style label id (from <name>.json)
  std::string content_label;   // "walk" (cfg label without the "dataset-N_" prefix)
  std::string style_label;     // "active"
  int take = 0;                // 1-based take number from the name
  int frames = 0;              // BVH frame count
  double duration = 0;         // seconds = frames * frame_time
  std::string bvh_path;        // absolute path of the unpacked .bvh
};

struct Manifest {
  std::string root;                                  // CACHE/bandai
  std::vector<ClipInfo> clips;                       // sorted by name
  std::vector<std::string> skipped;                  // "name: reason" for unreadable clips
  std::vector<std::string> content_labels[2];        // [dataset-1]; index = label id, prefix stripped
  std::vector<std::string> style_labels[2];
  double total_duration() const;                     // seconds
};

// Directory defaults. cache: $T2M_CACHE, else $HOME/.cache/t2m. data: $T2M_DATA, else the first existing of
// ./../shared/data/bandai, <exe dir>/../../shared/data/bandai, <exe dir>/../../../shared/data/bandai; "" if none.
std::string default_cache_dir();
std::string default_data_dir();

// Streams ARCHIVE (.tar.zst) into DEST_DIR (created). Regular files and directories only (others skipped).
// Returns the number of files written. Throws t2m::Error on corrupt zstd/tar data or I/O failure.
int extract_tar_zst(const std::string& archive, const std::string& dest_dir);

// Unpacks every data_dir/dataset-N.tar.zst not yet unpacked into cache_dir/bandai; returns cache_dir/bandai.
std::string unpack_dataset(const std::string& data_dir, const std::string& cache_dir);

// One line per label; trailing whitespace trimmed; empty lines dropped. Throws when the file cannot be read.
std::vector<std::string> read_label_file(const std::string& path);

// Splits "dataset-2_walk-turn-left_active_013" into dataset 2, content "walk-turn-left", style "active", take 13.
// Returns false when the name does not have that form.
bool parse_clip_name(const std::string& name, int* dataset, std::string* content, std::string* style, int* take);
// The content label of such a name ("walk-turn-left"), "" when the name does not have that form.
std::string clip_content(const std::string& name);

// Scans root (= CACHE/bandai) for *.bvh with their .json, labels from data_dir/cfg. Every clip is parsed fully
// and converted with sim::motion_from_bvh (OpenMP, in parallel) so that only usable clips enter the manifest;
// the others go to skipped with the reason. threads <= 0: OpenMP default.
Manifest build_manifest(const std::string& root, const std::string& data_dir, int threads = 0);

void save_manifest(const Manifest& m, const std::string& path);  // JSON, atomic
Manifest load_manifest(const std::string& path);                  // throws t2m::Error on missing/bad JSON

// unpack_dataset + build_manifest + save_manifest(CACHE/bandai/manifest.json); when the manifest exists and is
// newer than the markers and force is false, it is loaded instead of rebuilt.
Manifest prepare_dataset(const std::string& data_dir, const std::string& cache_dir, bool force = false);

// read_bvh + motion_from_bvh of one clip.
sim::Motion load_clip(const ClipInfo& clip);

}  // namespace t2m::data
