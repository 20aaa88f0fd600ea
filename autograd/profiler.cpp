// profiler.cpp — a thread-local pointer to the running Profiler; every hook takes one lap of the clock.
#include "autograd/profiler.h"

#include <algorithm>
#include <cstdio>

#include "tensor/tensor.h"

namespace t2m::ag {

namespace {
thread_local Profiler* tls_active = nullptr;
}  // namespace

Profiler::Profiler(bool by_shape) : by_shape_(by_shape) {
  if (tls_active) throw Error("Profiler: this thread is already being profiled (one Profiler at a time per thread)");
  start_ = last_ = Clock::now();
  tls_active = this;
}

Profiler::~Profiler() {
  if (tls_active == this) tls_active = nullptr;
}

Profiler* Profiler::active() { return tls_active; }

double Profiler::lap() {
  const Clock::time_point now = Clock::now();
  const double ms = std::chrono::duration<double, std::milli>(now - last_).count();
  last_ = now;
  return ms;
}

OpTime& Profiler::bucket(const std::string& op) {
  OpTime& t = ops_[op];
  if (t.op.empty()) t.op = op;
  return t;
}

std::string Profiler::key(const std::string& op, const std::vector<Shape>& shapes) const {
  if (!by_shape_) return op;
  std::string k = op;
  for (const Shape& s : shapes) k.append(1, ' ').append(shape_str(s));
  return k;
}

void Profiler::on_forward(const char* op, const std::vector<Shape>& shapes) {
  const double ms = lap();  // taken before the key is built (that string work lands on the next event)
  OpTime& t = bucket(key(op, shapes));
  t.fwd_ms += ms;
  ++t.calls;
}

void Profiler::on_backward(const std::string& op, const std::vector<Shape>& shapes) {
  const double ms = lap();
  OpTime& t = bucket(key(op, shapes));
  t.bwd_ms += ms;
  ++t.bwd_calls;
}

void Profiler::on_engine(const char* what) { bucket(what).bwd_ms += lap(); }

void Profiler::mark(const std::string& what) {
  OpTime& t = bucket(what);
  t.fwd_ms += lap();
  ++t.calls;
}

std::vector<OpTime> Profiler::ops() const {
  std::vector<OpTime> v;
  v.reserve(ops_.size());
  for (const auto& kv : ops_) v.push_back(kv.second);
  std::stable_sort(v.begin(), v.end(), [](const OpTime& a, const OpTime& b) { return a.total_ms() > b.total_ms(); });
  return v;
}

double Profiler::total_ms() const { return std::chrono::duration<double, std::milli>(last_ - start_).count(); }

std::string Profiler::table(int64_t steps, size_t max_rows) const {
  if (steps < 1) throw Error("Profiler::table: steps must be >= 1, got " + std::to_string(steps));
  const std::vector<OpTime> v = ops();
  const double total = total_ms(), s = double(steps);
  int w = 28;  // the name column: the longest name shown, 28 to 90 characters
  for (size_t i = 0; i < v.size() && i < max_rows; ++i) w = std::max(w, std::min(90, int(v[i].op.size())));
  std::string out;
  char line[256];
  std::snprintf(line, sizeof line, "%-*s %9s %9s %10s %10s %10s %6s\n", w, "op (per step)", "calls", "bwd calls",
                "fwd ms", "bwd ms", "total ms", "%");
  out += line;
  auto row = [&](const std::string& name, double calls, double bwd_calls, double fwd, double bwd) {
    std::snprintf(line, sizeof line, "%-*.*s %9.1f %9.1f %10.3f %10.3f %10.3f %5.1f%%\n", w, w, name.c_str(),
                  calls / s, bwd_calls / s, fwd / s, bwd / s, (fwd + bwd) / s,
                  total > 0 ? 100.0 * (fwd + bwd) / total : 0.0);
    out += line;
  };
  OpTime rest;
  for (size_t i = 0; i < v.size(); ++i) {
    if (i < max_rows) {
      row(v[i].op, double(v[i].calls), double(v[i].bwd_calls), v[i].fwd_ms, v[i].bwd_ms);
    } else {
      rest.calls += v[i].calls, rest.bwd_calls += v[i].bwd_calls;
      rest.fwd_ms += v[i].fwd_ms, rest.bwd_ms += v[i].bwd_ms;
    }
  }
  if (v.size() > max_rows) {
    char more[32];
    std::snprintf(more, sizeof more, "(%zu more)", v.size() - max_rows);
    row(more, double(rest.calls), double(rest.bwd_calls), rest.fwd_ms, rest.bwd_ms);
  }
  std::snprintf(line, sizeof line, "%-*s %9s %9s %10s %10s %10.3f %5.1f%%\n", w, "total", "", "", "", "", total / s,
                100.0);
  out += line;
  return out;
}

}  // namespace t2m::ag
