// test_cli_util.h — running the t2m binary from a test: it sits next to the test binary in the build directory
// (tests skip when it is not built); output goes to a log file the test can show on failure.
#pragma once
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace t2m::test {

inline std::string t2m_binary() {
  return (std::filesystem::read_symlink("/proc/self/exe").parent_path() / "t2m").string();
}

// `t2m ARGS > log 2>&1`; the exit status (-1 when it did not exit normally).
inline int run_t2m(const std::string& args, const std::filesystem::path& log) {
  std::string cmd = "'";
  cmd.append(t2m_binary()).append("' ").append(args).append(" > '").append(log.string()).append("' 2>&1");
  const int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

inline std::string read_text(const std::filesystem::path& p) {
  std::ifstream f(p);
  return std::string((std::istreambuf_iterator<char>(f)), {});
}

}  // namespace t2m::test
