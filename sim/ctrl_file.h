// ctrl_file.h — a searched demonstration on disk: the actuator targets applied per control step and the target
// offsets the search chose (sim/samcon.h, sim/samcon_mpc.h), as written by `t2m track-pd --samcon[-mpc]
// --export-dir DIR` to DIR/NAME.ctrl.json and read back by the BFM's demonstration loader (models/bfm).
//
//   save_ctrl_json(CtrlSequence{fps, nu, frames_searched, ctrl, offset}, path);   // atomic (tmp + rename)
//   CtrlSequence c = load_ctrl_json(path);                                      // checked
//
// JSON: {"format": "t2m-ctrl-1", "fps", "nu", "frames_searched", "ctrl": [steps * nu], "offset": [steps * nu]}
// where steps = frames - 1 of the reference clip (step t drives frame t -> t + 1) and frames_searched counts the
// reference frames reached while the search was in charge (after a failure the balance expert finished the clip).
// Errors (t2m::Error naming the file): unreadable or invalid JSON, wrong format tag, missing keys, nu < 1, ctrl
// and offset of different sizes or not a multiple of nu, frames_searched outside [0, steps], non-finite values.
#pragma once
#include <string>
#include <vector>

namespace t2m::sim {

struct CtrlSequence {
  double fps = 30;
  int nu = 0;
  int frames_searched = 0;
  std::vector<double> ctrl;    // [steps, nu] actuator targets applied
  std::vector<double> offset;  // [steps, nu] offsets to the balance expert's targets chosen by the search (rad)
  int steps() const { return nu > 0 ? (int)(ctrl.size() / (size_t)nu) : 0; }
};

void save_ctrl_json(const CtrlSequence& c, const std::string& path);
CtrlSequence load_ctrl_json(const std::string& path);

}  // namespace t2m::sim
