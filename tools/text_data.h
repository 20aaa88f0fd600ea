// text_data.h — shared by `t2m train text|evaluator` and `t2m eval motions`: the motion data set's clips of one
// split (manifest from `t2m data prepare`, splits from models/data/splits.h), the caption corpus seed, paths.
#pragma once
#include <map>
#include <string>
#include <vector>

#include "models/data/dataset.h"
#include "models/data/loader.h"
#include "models/data/splits.h"

namespace t2m::cli {

struct TextDataOptions {
  std::string data_dir, cache_dir;
  int threads = 0;
};

struct TextData {
  data::Manifest manifest;
  std::map<std::string, data::Split> splits;
};

// prepare_dataset (loads the existing manifest; unpacks on first use) + assign_splits. Throws t2m::Error with a
// hint when no data directory is found.
TextData load_text_data(const TextDataOptions& o);
std::vector<data::MotionClip> split_clips(const TextData& d, data::Split s, int threads);
// $HOME/.cache/t2m (or $T2M_CACHE) / sub.
std::string default_output_dir(const std::string& sub);
// Copies a file atomically (temp + rename in the destination's directory); creates the parent directory.
void copy_file_atomic(const std::string& from, const std::string& to);

}  // namespace t2m::cli
