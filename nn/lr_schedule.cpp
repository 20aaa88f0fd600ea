// lr_schedule.cpp — closed-form warm-up / cosine / constant schedules.
#include "nn/lr_schedule.h"

#include <cmath>
#include <numbers>
#include <sstream>

#include "tensor/tensor.h"

namespace t2m::nn {

LrSchedule LrSchedule::constant_lr(double base, int64_t warmup) {
  LrSchedule s;
  s.kind = Kind::constant;
  s.base = base;
  s.warmup = warmup;
  s.validate();
  return s;
}

LrSchedule LrSchedule::warmup_cosine(double base, int64_t warmup, int64_t total, double floor) {
  LrSchedule s;
  s.kind = Kind::cosine;
  s.base = base;
  s.warmup = warmup;
  s.total = total;
  s.floor = floor;
  s.validate();
  return s;
}

void LrSchedule::validate() const {
  if (!(base >= 0) || !std::isfinite(base)) throw Error("LrSchedule: base lr must be finite and >= 0, got " + std::to_string(base));
  if (warmup < 0) throw Error("LrSchedule: warmup must be >= 0, got " + std::to_string(warmup));
  if (kind == Kind::cosine) {
    if (!(floor >= 0 && floor <= base))
      throw Error("LrSchedule: floor must be in [0, base=" + std::to_string(base) + "], got " + std::to_string(floor));
    if (total <= warmup)
      throw Error("LrSchedule: total (" + std::to_string(total) + ") must exceed warmup (" + std::to_string(warmup) + ")");
  }
}

double LrSchedule::at(int64_t step) const {
  validate();
  if (step < 0) throw Error("LrSchedule: step must be >= 0, got " + std::to_string(step));
  if (step < warmup) return base * (double)(step + 1) / (double)warmup;
  if (kind == Kind::constant) return base;
  if (step >= total) return floor;
  const double progress = (double)(step - warmup) / (double)(total - warmup);
  return floor + (base - floor) * 0.5 * (1.0 + std::cos(std::numbers::pi * progress));
}

std::string LrSchedule::describe() const {
  std::ostringstream o;
  if (kind == Kind::constant)
    o << "constant base=" << base << " warmup=" << warmup;
  else
    o << "cosine base=" << base << " floor=" << floor << " warmup=" << warmup << " total=" << total;
  return o.str();
}

}  // namespace t2m::nn
