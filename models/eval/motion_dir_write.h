// motion_dir_write.h — writing a motions directory in the format `t2m eval motions` reads (motion_dir.h,
// docs/TEXT.md): what `t2m eval text2bfm` produces from generated or tracked motions.
//
// write_motion_dir(dir, entries, extra): every entry's features [frames, 257] go to DIR/<file> as a '<f4' .npy
// (write_npy_features) and DIR/motions.json lists them in order ({"format": "t2m-motions-1", "motions": [{"file",
// "caption", "prompt" (only when >= 0)}, ...]} plus the keys of `extra`, e.g. provenance). The directory is built
// as a hidden temporary sibling and renamed to DIR at the end, so DIR holds all files or none; an existing DIR is
// replaced only after the new one is complete.
// Errors (t2m::Error "motions DIR: ..."): no entries, an entry whose file is empty, absolute, contains "..", does
// not end in .npy, or repeats another's; features not (frames >= 1, 257); an empty caption; unwritable paths.
#pragma once
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/eval/motion_dir.h"

namespace t2m::eval {

void write_motion_dir(const std::string& dir, const std::vector<MotionEntry>& entries,
                      const nlohmann::json& extra = nlohmann::json::object());

}  // namespace t2m::eval
