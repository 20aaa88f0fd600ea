// train_config.h — what every resumable trainer's config shares: the optimisation budget (steps, batch, AdamW lr
// and weight decay, warm-up steps, seed) and the chunking (save_every, stop_at), plus the run's output paths.
// A trainer's config derives from TrainLoopConfig, sets its own defaults in its constructor and adds its own fields.
// common_json(): the keys that identify a run (steps, batch, lr, weight_decay, warmup, seed) — save_every and
// stop_at are not in it, so a later chunk may change them and still resume.
// validate_common(): throws t2m::Error "WHAT: bad config SHOWN (...)" unless steps >= 1, batch >= min_batch,
// save_every >= 1, lr > 0, weight_decay >= 0, 0 <= warmup < steps and stop_at >= 0.
// The trainers' common recipe: adamw() = AdamW(lr, weight_decay) with no decay on 1-D parameters (biases, norm
// gains); lr_schedule() = linear warm-up over `warmup` steps, then cosine to lr / 10 at `steps`; end_step() = the
// step this invocation stops at (stop_at when set, else steps).
#pragma once
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "nn/lr_schedule.h"
#include "nn/optim_adamw.h"

namespace t2m::nn {

struct TrainLoopConfig {
  int64_t steps = 1000;
  int64_t batch = 32;
  double lr = 3e-4;
  double weight_decay = 0.01;
  int64_t warmup = 100;
  uint64_t seed = 1;
  int64_t save_every = 100;
  int64_t stop_at = 0;  // > 0: save and return after this many steps in total (a resumable chunk)

  nlohmann::json common_json() const;
  void validate_common(const std::string& what, const nlohmann::json& shown, int64_t min_batch = 1) const;
  AdamWOptions adamw() const;
  LrSchedule lr_schedule() const;
  int64_t end_step() const { return stop_at > 0 && stop_at < steps ? stop_at : steps; }
};

// Where a run writes: the resumable state, the JSONL log and the loss plot (SVG).
struct TrainPaths {
  std::string state, log, svg;
};

// What one invocation of a trainer reports.
struct TrainRunResult {
  int64_t steps = 0;       // total steps done (this and earlier chunks)
  double final_loss = 0;   // the progress bar's smoothed loss
  double seconds = 0;      // wall time of this invocation
};

}  // namespace t2m::nn
