// profiler.h — where a forward/backward pass spends its wall time, op by op (torch.profiler's key_averages, with
// no tracing and no cost when off): while a Profiler lives, every op its thread records and every backward function
// the engine runs on that thread are timed and summed per op name.
//
// How time is attributed. The profiler keeps the time of the last event; each event gives the wall time since then
// to one bucket, so the buckets add up exactly to the time from the start to the last event:
//   - an op recorded on the tape (forward, with or without grad): since the last event -> that op's forward. An op
//     is recorded when its result is ready, so the glue before it (shape checks, views, a module's own code) counts
//     with it; an op built from other recorded ops shows as those ops (self time, as in PyTorch). So does any
//     work outside autograd (loading, I/O, a physics step): call mark() where it ends, or it lands on the next op.
//   - backward(): entering it -> "(untracked)"; each op's backward function -> that op's backward; summing the
//     gradients of a node or into a leaf's .grad -> "(grad accumulate)"; the engine's own walk -> "(engine)".
//   - mark(what): since the last event -> bucket `what` (e.g. "adamw" right after the optimizer step, so that its
//     time does not land on the next forward's first op).
// Only the thread that made the profiler is measured (OpenMP workers inside an op count as that op's wall time).
#pragma once
#include <chrono>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "tensor/tensor.h"

namespace t2m::ag {

struct OpTime {
  std::string op;
  int64_t calls = 0;      // forward events
  int64_t bwd_calls = 0;  // backward functions run
  double fwd_ms = 0, bwd_ms = 0;
  double total_ms() const { return fwd_ms + bwd_ms; }
};

class Profiler {
 public:
  // Starts measuring this thread; t2m::Error when a Profiler already measures it. by_shape: one bucket per op and
  // input shapes ("linear [256,16,512] [1536,512] [1536]"), as torch.profiler's group_by_input_shape.
  explicit Profiler(bool by_shape = false);
  ~Profiler();
  Profiler(const Profiler&) = delete;
  Profiler& operator=(const Profiler&) = delete;

  void mark(const std::string& what);  // the time since the last event goes to `what`

  std::vector<OpTime> ops() const;  // every bucket, largest total first
  double total_ms() const;          // from the start to the last event (= the sum of all buckets)

  // A table of the `max_rows` largest buckets (the rest summed in one row): calls and ms per step (divided by
  // `steps`), forward / backward / total, and % of total_ms().
  std::string table(int64_t steps = 1, size_t max_rows = 25) const;

  // The profiler measuring the calling thread, or nullptr (what the tape and the engine consult).
  static Profiler* active();
  bool by_shape() const { return by_shape_; }
  // Hooks: an op recorded / a backward function run (since the last event) / `what` of the engine. `shapes`: the
  // op's input shapes (used when by_shape()).
  void on_forward(const char* op, const std::vector<Shape>& shapes);
  void on_backward(const std::string& op, const std::vector<Shape>& shapes);
  void on_engine(const char* what);

 private:
  using Clock = std::chrono::steady_clock;
  double lap();  // ms since the last event; that event becomes now
  OpTime& bucket(const std::string& op);
  std::string key(const std::string& op, const std::vector<Shape>& shapes) const;

  bool by_shape_;
  Clock::time_point start_, last_;
  std::map<std::string, OpTime> ops_;
};

}  // namespace t2m::ag
