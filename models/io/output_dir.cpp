// output_dir.cpp — OutputDir: a hidden temporary sibling renamed into place (output_dir.h).
#include "models/io/output_dir.h"

#include <unistd.h>

#include "tensor/tensor.h"

namespace t2m::io {

namespace fs = std::filesystem;

namespace {

// ".NAME<tag>PID": a hidden sibling of the output directory.
fs::path hidden_sibling(const fs::path& target, const char* tag) {
  std::string s(1, '.');
  s.append(target.filename().string()).append(tag).append(std::to_string(::getpid()));
  return target.parent_path() / s;
}

}  // namespace

OutputDir::OutputDir(const std::string& dir, bool overwrite, const std::string& who) : who_(who) {
  if (dir.empty()) throw Error(who + ": --out is empty");
  const fs::path out = fs::absolute(fs::path(dir)).lexically_normal();
  target_ = out.has_filename() ? out : out.parent_path();
  std::error_code ec;
  if (fs::exists(target_, ec) && !overwrite && !(fs::is_directory(target_) && fs::is_empty(target_, ec)))
    throw Error(who + ": output directory " + target_.string() + " exists and is not empty (use --overwrite)");
  const fs::path parent = target_.parent_path();
  if (!fs::is_directory(parent, ec))
    throw Error(who + ": cannot write " + target_.string() + ": parent directory " + parent.string() +
                " does not exist");
  tmp_ = hidden_sibling(target_, ".tmp.");
  fs::remove_all(tmp_, ec);
  if (!fs::create_directory(tmp_, ec) || ec)
    throw Error(who + ": cannot write into " + parent.string() + ": " +
                (ec ? ec.message() : std::string("cannot create a directory")));
}

OutputDir::~OutputDir() {
  if (!committed_ && !tmp_.empty()) {
    std::error_code ec;
    fs::remove_all(tmp_, ec);
  }
}

void OutputDir::commit() {
  // An empty target is removed, an old one (overwrite) moved aside and deleted after the swap.
  std::error_code ec;
  fs::path old;
  if (fs::exists(target_, ec)) {
    if (fs::is_directory(target_) && fs::is_empty(target_, ec)) {
      fs::remove(target_, ec);
    } else {
      old = hidden_sibling(target_, ".old.");
      fs::remove_all(old, ec);
      fs::rename(target_, old, ec);
      if (ec) throw Error(who_ + ": cannot replace " + target_.string() + ": " + ec.message());
    }
  }
  fs::rename(tmp_, target_, ec);
  if (ec) {
    if (!old.empty()) fs::rename(old, target_, ec);
    throw Error(who_ + ": cannot move the outputs to " + target_.string() + ": " + ec.message());
  }
  committed_ = true;
  if (!old.empty()) fs::remove_all(old, ec);
}

}  // namespace t2m::io
