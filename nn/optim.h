// optim.h — the optimizer base shared by AdamW (nn/optim_adamw.h) and SGD (nn/optim_sgd.h).
//
// An optimizer owns a list of named parameters (usually Module::named_parameters()) and, per parameter, a fixed
// set of state "slots" (AdamW: exp_avg, exp_avg_sq; SGD: momentum_buffer), each a tensor of the parameter's shape
// and dtype. step() applies one update from the parameters' .grad() and increments step_count(); parameters whose
// grad is undefined (never reached by backward) are skipped, their state untouched. The step count is one per
// optimizer, not per parameter as in torch: a parameter skipped for k steps sees bias corrections / first-step
// rules of the global count afterwards (identical to torch when every parameter gets a grad every step). The learning rate is set from
// outside before each step (nn/lr_schedule.h gives it as a pure function of step_count()).
//
// State in a checkpoint, under `prefix` (e.g. "optim."):
//   PREFIX + "step"                  int64 [1]  updates done so far
//   PREFIX + SLOT + "." + PARAM_NAME  the slot tensor of that parameter, same shape/dtype as the parameter
// check_state() validates a checkpoint without modifying anything (missing name, shape/dtype mismatch, a slot
// tensor for an unknown parameter, a negative step); load_from() runs it and then copies, so a failed load leaves
// the optimizer as it was.
// Errors (t2m::Error naming the optimizer): empty or duplicate parameter names, the same Variable twice, an
// undefined or non-float parameter, a non-contiguous parameter, a grad whose shape/dtype differs from its
// parameter, lr < 0.
#pragma once
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "autograd/variable.h"
#include "nn/checkpoint.h"

namespace t2m::nn {

using NamedParams = std::vector<std::pair<std::string, ag::Variable>>;

class Optimizer {
 public:
  virtual ~Optimizer() = default;
  Optimizer(const Optimizer&) = delete;
  Optimizer& operator=(const Optimizer&) = delete;

  virtual void step() = 0;  // one update; step_count() += 1
  void zero_grad();         // every parameter's grad to zero (memory kept)

  double lr() const { return lr_; }
  void set_lr(double lr);
  int64_t step_count() const { return step_; }
  const NamedParams& params() const { return params_; }
  const std::string& kind() const { return kind_; }  // "AdamW", "SGD" (for messages)

  // The state tensor of `slot` for parameter index i (for inspection and tests).
  const Tensor& state(const std::string& slot, size_t i) const;
  const std::vector<std::string>& slots() const { return slot_names_; }

  void save_to(Checkpoint& ck, const std::string& prefix) const;
  void check_state(const Checkpoint& ck, const std::string& prefix) const;  // throws; changes nothing
  void load_from(const Checkpoint& ck, const std::string& prefix);

 protected:
  Optimizer(std::string kind, NamedParams params, double lr, std::vector<std::string> slot_names);
  // The grad of parameter i as a contiguous tensor, or an undefined tensor when it has none (checked).
  Tensor grad_of(size_t i) const;

  std::string kind_;
  NamedParams params_;
  double lr_ = 0.0;
  int64_t step_ = 0;
  std::vector<std::string> slot_names_;
  std::vector<std::vector<Tensor>> state_;  // [slot][param], zero-initialised
};

}  // namespace t2m::nn
