// atomic_file.cpp — temp file + rename (see atomic_file.h).
#include "sim/atomic_file.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "tensor/tensor.h"

namespace t2m::sim {

void write_text_atomic(const std::string& path, const std::string& text, const char* who) {
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  const auto fail = [&](const char* what, int err) {
    std::remove(tmp.c_str());
    throw Error(std::string(who) + ": cannot write '" + path + "' (" + what + ": " + std::strerror(err) + ")");
  };
  FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) fail("create", errno);
  const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size();
  const int werr = errno;
  if (std::fclose(f) != 0 || !ok) fail("write", ok ? errno : werr);
  if (std::rename(tmp.c_str(), path.c_str()) != 0) fail("rename", errno);
}

}  // namespace t2m::sim
