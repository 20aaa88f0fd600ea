// train_log.h — the JSON-lines training log and an SVG loss-curve plot made from it.
//
// TrainLog appends one JSON object per line ({"step": 100, "loss": 0.031, "lr": 4.9e-05, ...}) and flushes after
// each, so a crash loses at most the line being written. On resume, TrainLog(path, resume_step) first drops
// records whose "step" exceeds resume_step (written after the checkpoint being resumed), rewriting the file
// atomically, so the log matches the resumed run.
// read_train_log: parses every line; a malformed final line without a trailing newline (a crash mid-write) is
// skipped, a malformed line elsewhere throws naming the file and line number.
// loss_curve_svg: plain SVG 1.1 text: axes with tick labels, one <polyline> per series (x = opts.x, y = each key;
// keys default to every numeric field except x, in order of first appearance), legend, optional log10 y axis
// (values <= 0 are left out there); non-finite values and records without the key are skipped.
// Errors (t2m::Error naming the path): cannot open/write; a record that is not an object; no data to plot
// (no record has x and a plottable y).
#pragma once
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace t2m::nn {

class TrainLog {
 public:
  explicit TrainLog(std::string path, int64_t resume_step = -1);
  ~TrainLog();
  TrainLog(const TrainLog&) = delete;
  TrainLog& operator=(const TrainLog&) = delete;

  void write(const nlohmann::json& record);  // one line, flushed
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  FILE* f_ = nullptr;
};

std::vector<nlohmann::json> read_train_log(const std::string& path);

struct SvgPlotOptions {
  std::string x = "step";
  std::vector<std::string> keys;  // empty: every numeric key except x
  bool log_y = false;
  int width = 800;
  int height = 480;
  std::string title;
};

std::string loss_curve_svg(const std::vector<nlohmann::json>& records, const SvgPlotOptions& opt = {});
void write_loss_svg(const std::string& log_path, const std::string& svg_path, const SvgPlotOptions& opt = {});

}  // namespace t2m::nn
