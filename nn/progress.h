// progress.h — a progress bar for long commands, written to stderr (or any FILE*).
//
//   nn::ProgressOptions po; po.start = ts.step;
//   nn::Progress bar(total_steps, "train vbb", po);
//   for (...) { ...; bar.update(ts.step, {{"loss", loss}, {"kl", kl}}); }
//   bar.finish();
// Line: "train vbb  [#########.........]  1200/5000  24%  35.2 it/s  ETA 1m48s  loss 0.0312  kl 1.2e-03"
//   rate = (step - start) / seconds since construction (steps done in THIS process; resume-safe), ETA from it.
//   Values are smoothed with a bias-corrected exponential average (weight `smoothing` on the newest value;
//   1 = no smoothing), each name separately, shown in the order first seen.
// TTY (isatty(fileno(out)), or opt.tty forced): the line is redrawn in place ("\r" + line + erase-to-end) at most
// every redraw_s seconds; finish() ends it with a newline. Non-TTY (logs, pipes): one full line every
// interval_s seconds, plus one at finish(). The clock can be injected for tests.
// Errors (t2m::Error "Progress: ..."): total < 0, start > total, smoothing outside (0, 1], interval_s < 0.
#pragma once
#include <cstdint>
#include <cstdio>
#include <functional>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

namespace t2m::nn {

struct ProgressOptions {
  int64_t start = 0;         // the step this run starts from (resume)
  FILE* out = stderr;
  int tty = -1;              // -1: detect, 0: plain lines, 1: redraw in place
  double interval_s = 10.0;  // non-TTY: seconds between lines
  double redraw_s = 0.1;     // TTY: minimum seconds between redraws
  double smoothing = 0.1;
  int bar_width = 24;
  std::function<double()> clock;  // seconds, monotonic; default steady_clock
};

class Progress {
 public:
  Progress(int64_t total, std::string label = "", ProgressOptions opt = {});
  ~Progress();  // finish() if not yet done (never throws)
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void update(int64_t step, std::initializer_list<std::pair<std::string, double>> values = {});
  void update(int64_t step, const std::vector<std::pair<std::string, double>>& values);
  void finish();

  std::string line() const;             // the current line (no control characters)
  double smoothed(const std::string& name) const;  // NaN when never given
  double rate() const;                  // steps per second in this run (0 before any progress)
  bool is_tty() const { return tty_; }

 private:
  void emit(bool final);
  double now() const;
  int64_t total_;
  std::string label_;
  ProgressOptions opt_;
  bool tty_;
  bool done_ = false;
  int64_t step_;
  double t0_, last_emit_ = -1e300;
  std::vector<std::string> names_;
  std::vector<double> avg_, weight_;  // biased average and its total weight, per name
};

// "1h02m03s", "4m05s", "12s", "--" for non-finite or negative.
std::string format_duration(double seconds);

}  // namespace t2m::nn
