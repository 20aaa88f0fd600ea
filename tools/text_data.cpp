// text_data.cpp — data set access and paths for the text-side commands.
#include "tools/text_data.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include "nn/checkpoint.h"
#include "tensor/tensor.h"

namespace t2m::cli {

TextData load_text_data(const TextDataOptions& o) {
  std::string d = o.data_dir.empty() ? data::default_data_dir() : o.data_dir;
  const std::string c = o.cache_dir.empty() ? data::default_cache_dir() : o.cache_dir;
  if (d.empty() && !std::filesystem::exists(c + "/bandai/manifest.json"))
    throw Error("no data directory found (looked at $T2M_DATA and ../shared/data/bandai); pass --data DIR");
  TextData t;
  t.manifest = d.empty() ? data::load_manifest(c + "/bandai/manifest.json") : data::prepare_dataset(d, c, false);
  std::vector<std::string> names;
  for (const auto& clip : t.manifest.clips) names.push_back(clip.name);
  t.splits = data::assign_splits(names);
  return t;
}

std::vector<data::MotionClip> split_clips(const TextData& d, data::Split s, int threads) {
  return data::load_split_clips(d.manifest, d.splits, s, threads);
}

std::string default_output_dir(const std::string& sub) { return data::default_cache_dir() + "/" + sub; }

void copy_file_atomic(const std::string& from, const std::string& to) {
  std::ifstream in(from, std::ios::binary);
  if (!in) throw Error("cannot read '" + from + "'");
  std::ostringstream ss;
  ss << in.rdbuf();
  const auto parent = std::filesystem::path(to).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent);
  nn::write_file_atomic(to, ss.str());
}

}  // namespace t2m::cli
