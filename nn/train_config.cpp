// train_config.cpp — the shared part of the trainers' configs.
#include "nn/train_config.h"

#include "tensor/tensor.h"

namespace t2m::nn {

nlohmann::json TrainLoopConfig::common_json() const {
  return {{"steps", steps}, {"batch", batch}, {"lr", lr}, {"weight_decay", weight_decay}, {"warmup", warmup},
          {"seed", seed}};
}

void TrainLoopConfig::validate_common(const std::string& what, const nlohmann::json& shown, int64_t min_batch) const {
  if (steps < 1 || batch < min_batch || !(lr > 0) || weight_decay < 0 || warmup < 0 || warmup >= steps ||
      save_every < 1 || stop_at < 0)
    throw Error(what + ": bad config " + shown.dump() + " (steps, save_every >= 1, batch >= " +
                std::to_string(min_batch) + ", lr > 0, weight_decay >= 0, 0 <= warmup < steps, stop_at >= 0)");
}

AdamWOptions TrainLoopConfig::adamw() const {
  AdamWOptions o;
  o.lr = lr;
  o.weight_decay = weight_decay;
  o.no_decay = no_decay_1d;
  return o;
}

LrSchedule TrainLoopConfig::lr_schedule() const { return LrSchedule::warmup_cosine(lr, warmup, steps, lr / 10); }

}  // namespace t2m::nn
