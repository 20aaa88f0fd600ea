// anomaly.h — anomaly mode: while enabled (thread-local, default off), backward checks every gradient an op
// produces and throws t2m::Error naming the op and the input as soon as one holds a NaN or an infinity
// ("backward: op 'sqrt' produced a non-finite gradient for input 0 of shape [3]"). Costs one reduction per
// gradient; meant for debugging a diverging training run, not for production.
#pragma once

namespace t2m::ag {

struct AnomalyMode {
  static bool is_enabled();
  static void set_enabled(bool enabled);
};

// RAII: enables anomaly checks for its lifetime, then restores the previous mode.
class DetectAnomalyGuard {
 public:
  DetectAnomalyGuard() : prev_(AnomalyMode::is_enabled()) { AnomalyMode::set_enabled(true); }
  ~DetectAnomalyGuard() { AnomalyMode::set_enabled(prev_); }
  DetectAnomalyGuard(const DetectAnomalyGuard&) = delete;
  DetectAnomalyGuard& operator=(const DetectAnomalyGuard&) = delete;

 private:
  bool prev_;
};

}  // namespace t2m::ag
