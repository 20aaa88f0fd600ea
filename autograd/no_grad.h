// no_grad.h — grad mode: whether autograd ops record nodes on the tape (thread-local, default on).
//
//   { ag::NoGradGuard g; auto y = ag::mul(x, w); }   // y has no grad_fn, saves nothing (inference)
//
// The mode is per thread: a guard on one thread does not affect ops running on another.
#pragma once

namespace t2m::ag {

struct GradMode {
  static bool is_enabled();
  static void set_enabled(bool enabled);
};

// RAII: disables recording for its lifetime, then restores the previous mode (guards nest).
class NoGradGuard {
 public:
  NoGradGuard() : prev_(GradMode::is_enabled()) { GradMode::set_enabled(false); }
  ~NoGradGuard() { GradMode::set_enabled(prev_); }
  NoGradGuard(const NoGradGuard&) = delete;
  NoGradGuard& operator=(const NoGradGuard&) = delete;

 private:
  bool prev_;
};

}  // namespace t2m::ag
