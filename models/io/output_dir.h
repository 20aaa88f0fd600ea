// output_dir.h — an output directory that appears all at once or not at all (what `t2m generate` writes).
//
//   OutputDir d("/home/me/walk", overwrite, "generate");   // checks, creates the hidden sibling /home/me/.walk.tmp.PID
//   write files into d.tmp() ...
//   d.commit();                                             // renames it into place
//
// The target must not exist or be an empty directory, unless `overwrite` (an existing one is then replaced only
// once the new one is complete). Its parent must exist. Without commit() (an exception on the way), the destructor
// removes the temporary directory, so nothing half-written is left behind.
// Errors (t2m::Error "<who>: ..."): empty path, a non-empty target without overwrite, a missing parent, an
// unwritable parent, a failed rename.
#pragma once
#include <filesystem>
#include <string>

namespace t2m::io {

class OutputDir {
 public:
  OutputDir(const std::string& dir, bool overwrite, const std::string& who);
  ~OutputDir();
  OutputDir(const OutputDir&) = delete;
  OutputDir& operator=(const OutputDir&) = delete;

  const std::filesystem::path& tmp() const { return tmp_; }        // write here
  const std::filesystem::path& target() const { return target_; }  // where it ends up
  std::string file(const std::string& name) const { return (tmp_ / name).string(); }
  void commit();

 private:
  std::filesystem::path target_, tmp_;
  std::string who_;
  bool committed_ = false;
};

}  // namespace t2m::io
