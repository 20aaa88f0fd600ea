// test_scratch_dir.h — scratch space for one test process: <system temp dir>/<test binary>_<pid>, made on first
// use and removed with everything in it when the process exits, so a passing run leaves nothing behind in /tmp; kept
// (and its path printed) when a test failed, for a look at what it wrote. ctest runs every test case in its own
// process, so cases never share it.
#pragma once
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>

namespace t2m::test {

namespace detail {
struct ScratchRoot {
  std::filesystem::path path;
  pid_t owner = ::getpid();  // a forked child that exits must not remove its parent's directory
  ScratchRoot() {
    const std::string exe = std::filesystem::read_symlink("/proc/self/exe").filename().string();
    path = std::filesystem::temp_directory_path() / (exe + "_" + std::to_string(owner));
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
  }
  ~ScratchRoot() {
    if (::getpid() != owner) return;
    if (::testing::UnitTest::GetInstance()->Failed()) {
      std::fprintf(stderr, "test_scratch_dir: kept %s (a test failed)\n", path.c_str());
      return;
    }
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};
}  // namespace detail

// This process's scratch directory (exists).
inline const std::filesystem::path& scratch_root() {
  static const detail::ScratchRoot root;
  return root.path;
}

// scratch_root()/name as a fresh, empty directory.
inline std::filesystem::path scratch_dir(const std::string& name) {
  const std::filesystem::path d = scratch_root() / name;
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

}  // namespace t2m::test
