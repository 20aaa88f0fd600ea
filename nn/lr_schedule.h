// lr_schedule.h — learning rate as a pure function of the update index (so a resumed run recomputes it exactly).
//
// `step` is the number of updates already done (Optimizer::step_count() before the update; 0 for the first).
//   warm-up   step < warmup:          lr = base * (step + 1) / warmup        (reaches base at step warmup - 1)
//   cosine    warmup <= step < total: lr = floor + (base - floor) * (1 + cos(pi * (step - warmup) / (total - warmup))) / 2
//             step >= total:          lr = floor
//   constant  after the warm-up:      lr = base
// Errors (t2m::Error "LrSchedule: ..."): base < 0, floor < 0 or > base, warmup < 0, total <= warmup for cosine,
// step < 0.
#pragma once
#include <cstdint>
#include <string>

namespace t2m::nn {

struct LrSchedule {
  enum class Kind { constant, cosine };
  Kind kind = Kind::cosine;
  double base = 1e-3;
  double floor = 0.0;      // cosine only: the final learning rate
  int64_t warmup = 0;      // linear warm-up updates (0: none)
  int64_t total = 1;       // cosine only: updates until the floor

  static LrSchedule constant_lr(double base, int64_t warmup = 0);
  static LrSchedule warmup_cosine(double base, int64_t warmup, int64_t total, double floor = 0.0);

  double at(int64_t step) const;  // the learning rate for the update after `step` updates
  void validate() const;          // throws on bad settings
  std::string describe() const;   // "cosine base=0.001 floor=1e-05 warmup=100 total=10000"
};

}  // namespace t2m::nn
