// motion_dir_write.cpp — motions directory writer: .npy files + motions.json in a temporary sibling, then rename.
#include "models/eval/motion_dir_write.h"

#include <filesystem>
#include <set>
#include <unistd.h>

#include "models/data/features.h"
#include "nn/checkpoint.h"
#include "tensor/tensor.h"

namespace t2m::eval {

namespace fs = std::filesystem;

void write_motion_dir(const std::string& dir, const std::vector<MotionEntry>& entries, const nlohmann::json& extra) {
  const std::string who = "motions " + dir + ": ";
  if (entries.empty()) throw Error(who + "no motions to write");
  std::set<std::string> seen;
  for (size_t i = 0; i < entries.size(); ++i) {
    const MotionEntry& e = entries[i];
    const std::string at = "entry " + std::to_string(i) + " ";
    const fs::path p(e.file);
    if (e.file.empty() || p.is_absolute() || e.file.find("..") != std::string::npos || p.extension() != ".npy")
      throw Error(who + at + "file '" + e.file + "' must be a relative .npy path inside the directory");
    if (!seen.insert(e.file).second) throw Error(who + at + "repeats the file '" + e.file + "'");
    if (e.caption.empty()) throw Error(who + at + "has an empty caption");
    if (e.frames < 1 || (int64_t)e.features.size() != e.frames * data::kFeatureDim)
      throw Error(who + at + "features are not (" + std::to_string(e.frames) + " >= 1, 257)");
  }
  const fs::path target = fs::absolute(fs::path(dir)).lexically_normal();
  const fs::path parent = target.parent_path();
  std::error_code ec;
  fs::create_directories(parent, ec);
  if (ec) throw Error(who + "cannot create " + parent.string() + ": " + ec.message());
  const std::string base = target.filename().string(), pid = std::to_string(::getpid());
  std::string tmp_name = ".", old_name = ".";
  tmp_name.append(base).append(".tmp").append(pid);
  old_name.append(base).append(".old").append(pid);
  const fs::path tmp = parent / tmp_name;
  fs::remove_all(tmp, ec);
  try {
    fs::create_directories(tmp);
    nlohmann::json list = nlohmann::json::array();
    for (const MotionEntry& e : entries) {
      const fs::path f = tmp / e.file;
      fs::create_directories(f.parent_path());
      write_npy_features(f.string(), e.features, data::kFeatureDim);
      nlohmann::json j = {{"file", e.file}, {"caption", e.caption}};
      if (e.prompt >= 0) j["prompt"] = e.prompt;
      list.push_back(j);
    }
    nlohmann::json m = extra.is_object() ? extra : nlohmann::json::object();
    m["format"] = "t2m-motions-1";
    m["motions"] = list;
    nn::write_file_atomic((tmp / "motions.json").string(), m.dump(1) + "\n");
    if (fs::exists(target)) {
      const fs::path old = parent / old_name;
      fs::rename(target, old);
      fs::rename(tmp, target);
      fs::remove_all(old);
    } else {
      fs::rename(tmp, target);
    }
  } catch (const fs::filesystem_error& e) {
    fs::remove_all(tmp, ec);
    throw Error(who + "cannot write: " + e.what());
  } catch (...) {
    fs::remove_all(tmp, ec);
    throw;
  }
}

}  // namespace t2m::eval
