// fb_optimizer.h — AdamW over the FB agent's two trained parameter groups (F + B, and the actor), each with its
// own learning rate, in one nn::Optimizer so a single nn::TrainState saves and restores both (kind "FbAdamW").
//
// step_group(g): one AdamW update (nn/optim_adamw.h arithmetic, fused multi-tensor kernel) of group g's
//   parameters that have a grad, with bias-correction step t = step_count() + 1; the count is NOT advanced.
// finish_step(): advances the count by one (after both groups took their step of this update).
// step(): step_group(kFb), step_group(kActor), finish_step().
// State slots "exp_avg", "exp_avg_sq" (nn/optim.h layout), so resuming is bit-identical.
// float32 parameters only. Errors (t2m::Error "FbOptimizer: ..."): a group id outside {0, 1}, group list size
// differing from the parameter list, a float64 parameter, plus nn/optim.h's.
#pragma once
#include <vector>

#include "nn/optim.h"

namespace t2m::bfm {

class FbOptimizer : public nn::Optimizer {
 public:
  static constexpr int kFb = 0, kActor = 1;
  FbOptimizer(nn::NamedParams params, std::vector<int> group, double lr_fb, double lr_actor,
              double weight_decay = 0.0, double beta1 = 0.9, double beta2 = 0.999, double eps = 1e-8);
  void step() override;
  void step_group(int g);
  void finish_step() { ++step_; }
  void set_group_lr(int g, double lr);
  double group_lr(int g) const;

 private:
  std::vector<int> group_;
  double lr_actor_, wd_, b1_, b2_, eps_;
};

}  // namespace t2m::bfm
