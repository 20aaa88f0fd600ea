// ctrl_file.cpp — reading and writing NAME.ctrl.json (see ctrl_file.h).
#include "sim/ctrl_file.h"

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "sim/atomic_file.h"
#include "tensor/tensor.h"

namespace t2m::sim {
namespace {

void check(const CtrlSequence& c, const std::string& who, const std::string& path) {
  const size_t n = c.ctrl.size();
  const auto bad = [&](const std::string& what) { throw Error(who + ": '" + path + "': " + what); };
  if (c.nu < 1) bad("nu must be >= 1, got " + std::to_string(c.nu));
  if (!(c.fps > 0) || !std::isfinite(c.fps)) bad("fps must be positive");
  if (c.offset.size() != n || n % (size_t)c.nu != 0)
    bad(std::to_string(n) + " ctrl and " + std::to_string(c.offset.size()) + " offset values for nu " +
        std::to_string(c.nu) + " (need equal sizes, a multiple of nu)");
  if (c.frames_searched < 0 || c.frames_searched > c.steps())
    bad("frames_searched " + std::to_string(c.frames_searched) + " outside [0, " + std::to_string(c.steps()) + "]");
  for (size_t i = 0; i < n; ++i)
    if (!std::isfinite(c.ctrl[i]) || !std::isfinite(c.offset[i])) bad("non-finite value at " + std::to_string(i));
}

}  // namespace

void save_ctrl_json(const CtrlSequence& c, const std::string& path) {
  check(c, "save_ctrl_json", path);
  const nlohmann::json j = {{"format", "t2m-ctrl-1"},           {"fps", c.fps},   {"nu", c.nu},
                            {"frames_searched", c.frames_searched}, {"ctrl", c.ctrl}, {"offset", c.offset}};
  write_text_atomic(path, j.dump() + "\n", "save_ctrl_json");
}

CtrlSequence load_ctrl_json(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw Error("load_ctrl_json: cannot open '" + path + "'");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(f);
  } catch (const std::exception& e) {
    throw Error("load_ctrl_json: '" + path + "' is not valid JSON: " + e.what());
  }
  CtrlSequence c;
  try {
    if (j.at("format").get<std::string>() != "t2m-ctrl-1") throw Error("wrong format tag (want t2m-ctrl-1)");
    c.fps = j.at("fps").get<double>();
    c.nu = j.at("nu").get<int>();
    c.frames_searched = j.at("frames_searched").get<int>();
    c.ctrl = j.at("ctrl").get<std::vector<double>>();
    c.offset = j.at("offset").get<std::vector<double>>();
  } catch (const std::exception& e) {
    throw Error("load_ctrl_json: '" + path + "': bad content (" + e.what() + ")");
  }
  check(c, "load_ctrl_json", path);
  return c;
}

}  // namespace t2m::sim
