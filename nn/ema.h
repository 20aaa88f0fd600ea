// ema.h — exponential moving average of weights, for evaluation with the averaged model.
//
//   d_t = warmup ? min(decay, (1 + t) / (10 + t)) : decay      t = updates done before this one (0 first)
//   shadow <- d_t shadow + (1 - d_t) param                      (arithmetic in double, stored in the param dtype)
// The shadow starts as a copy of the parameters at construction. apply() swaps the shadow values into the
// parameters (keeping a backup); restore() puts the training values back. EmaScope does both as RAII.
// Checkpoint layout under `prefix` (e.g. "ema."): PREFIX + "num_updates" int64 [1]; PREFIX + NAME per parameter.
// check_state() validates without changes; load_from() checks then copies. Loading while applied is an error.
// Errors (t2m::Error "Ema: ..."): decay outside [0, 1]; empty/duplicate names; apply() twice; restore() without
// apply(); update() while applied; a checkpoint with a missing/extra name or a shape/dtype mismatch.
#pragma once
#include "nn/optim.h"

namespace t2m::nn {

class Ema {
 public:
  Ema(NamedParams params, double decay, bool warmup = false);

  void update();                      // one EMA step from the current parameter values
  double decay_at(int64_t t) const;   // d_t as above
  int64_t num_updates() const { return updates_; }
  const Tensor& shadow(size_t i) const { return shadow_.at(i); }

  void apply();    // parameters <- shadow (training values kept aside)
  void restore();  // parameters <- training values
  bool applied() const { return applied_; }

  void save_to(Checkpoint& ck, const std::string& prefix) const;
  void check_state(const Checkpoint& ck, const std::string& prefix) const;
  void load_from(const Checkpoint& ck, const std::string& prefix);

 private:
  NamedParams params_;
  double decay_;
  bool warmup_;
  int64_t updates_ = 0;
  bool applied_ = false;
  std::vector<Tensor> shadow_, backup_;
};

// RAII: apply() now, restore() at scope exit (also on exceptions).
class EmaScope {
 public:
  explicit EmaScope(Ema& ema) : ema_(ema) { ema_.apply(); }
  ~EmaScope() { if (ema_.applied()) ema_.restore(); }
  EmaScope(const EmaScope&) = delete;
  EmaScope& operator=(const EmaScope&) = delete;

 private:
  Ema& ema_;
};

}  // namespace t2m::nn
