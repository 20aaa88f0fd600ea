// progress.cpp — line formatting, smoothing, TTY redraw vs timed plain lines.
#include "nn/progress.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

#include "tensor/tensor.h"

namespace t2m::nn {

std::string format_duration(double s) {
  if (!std::isfinite(s) || s < 0) return "--";
  const int64_t t = (int64_t)std::llround(s);
  char buf[64];
  if (t >= 3600)
    std::snprintf(buf, sizeof buf, "%lldh%02lldm%02llds", (long long)(t / 3600), (long long)(t / 60 % 60), (long long)(t % 60));
  else if (t >= 60)
    std::snprintf(buf, sizeof buf, "%lldm%02llds", (long long)(t / 60), (long long)(t % 60));
  else
    std::snprintf(buf, sizeof buf, "%llds", (long long)t);
  return buf;
}

Progress::Progress(int64_t total, std::string label, ProgressOptions opt)
    : total_(total), label_(std::move(label)), opt_(std::move(opt)), step_(opt_.start) {
  if (total_ < 0) throw Error("Progress: total must be >= 0, got " + std::to_string(total_));
  if (opt_.start < 0 || opt_.start > total_)
    throw Error("Progress: start " + std::to_string(opt_.start) + " outside [0, total=" + std::to_string(total_) + "]");
  if (!(opt_.smoothing > 0 && opt_.smoothing <= 1))
    throw Error("Progress: smoothing must be in (0, 1], got " + std::to_string(opt_.smoothing));
  if (!(opt_.interval_s >= 0) || !(opt_.redraw_s >= 0)) throw Error("Progress: interval_s/redraw_s must be >= 0");
  if (!opt_.out) throw Error("Progress: null output stream");
  tty_ = opt_.tty >= 0 ? opt_.tty == 1 : ::isatty(::fileno(opt_.out)) == 1;
  t0_ = now();
  if (!tty_) last_emit_ = t0_;  // first plain line after interval_s
}

Progress::~Progress() {
  try {
    if (!done_) finish();
  } catch (...) {
  }
}

double Progress::now() const {
  if (opt_.clock) return opt_.clock();
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

double Progress::rate() const {
  const double dt = now() - t0_;
  return (dt > 0 && step_ > opt_.start) ? (double)(step_ - opt_.start) / dt : 0.0;
}

double Progress::smoothed(const std::string& name) const {
  for (size_t i = 0; i < names_.size(); ++i)
    if (names_[i] == name) return avg_[i] / weight_[i];
  return std::numeric_limits<double>::quiet_NaN();
}

void Progress::update(int64_t step, std::initializer_list<std::pair<std::string, double>> values) {
  update(step, std::vector<std::pair<std::string, double>>(values));
}

void Progress::update(int64_t step, const std::vector<std::pair<std::string, double>>& values) {
  step_ = step;
  const double a = opt_.smoothing;
  for (const auto& [name, v] : values) {
    size_t i = 0;
    while (i < names_.size() && names_[i] != name) ++i;
    if (i == names_.size()) {
      names_.push_back(name);
      avg_.push_back(0.0);
      weight_.push_back(0.0);
    }
    // Bias-corrected EMA: avg/weight is the weighted mean with weights a(1-a)^k on the k-th newest value.
    avg_[i] = (1 - a) * avg_[i] + a * v;
    weight_[i] = (1 - a) * weight_[i] + a;
  }
  const double t = now();
  if (t - last_emit_ >= (tty_ ? opt_.redraw_s : opt_.interval_s)) {
    last_emit_ = t;
    emit(false);
  }
}

std::string Progress::line() const {
  std::string s;
  if (!label_.empty()) s.append(label_).append("  ");
  const double frac = total_ > 0 ? std::min(1.0, std::max(0.0, (double)step_ / (double)total_)) : 1.0;
  const int w = opt_.bar_width > 0 ? opt_.bar_width : 0;
  if (w > 0) {
    const int filled = (int)std::floor(frac * w);
    s.push_back('[');
    s.append((size_t)filled, '#').append((size_t)(w - filled), '.').append("]  ");
  }
  char buf[160];
  const double r = rate();
  const double eta = r > 0 ? (double)(total_ - step_) / r : std::numeric_limits<double>::infinity();
  std::snprintf(buf, sizeof buf, "%lld/%lld  %3d%%  %.3g it/s  ETA %s", (long long)step_, (long long)total_,
                (int)std::floor(frac * 100), r, format_duration(eta).c_str());
  s += buf;
  for (size_t i = 0; i < names_.size(); ++i) {
    std::snprintf(buf, sizeof buf, "  %s %.4g", names_[i].c_str(), avg_[i] / weight_[i]);
    s += buf;
  }
  return s;
}

void Progress::emit(bool final) {
  const std::string l = line();
  if (tty_)
    std::fprintf(opt_.out, "\r%s\033[K%s", l.c_str(), final ? "\n" : "");
  else
    std::fprintf(opt_.out, "%s\n", l.c_str());
  std::fflush(opt_.out);
}

void Progress::finish() {
  if (done_) return;
  done_ = true;
  emit(true);
}

}  // namespace t2m::nn
