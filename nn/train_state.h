// train_state.h — one atomic checkpoint holding everything a training run needs to resume BIT-identically:
// model parameters, optimizer state, EMA shadow, Generator states (seed, offset), step, epoch, cursor, config.
//
// Usage: a resumable training loop in chunks (later `t2m train X --resume` commands follow this shape).
//   auto params = model.named_parameters();
//   nn::AdamWOptions ao; ao.lr = 5e-5; ao.weight_decay = 5e-4; ao.no_decay = nn::no_decay_1d;
//   nn::AdamW opt(params, ao);
//   nn::Ema ema(params, 0.999, /*warmup=*/true);
//   t2m::Generator data_rng(seed), drop_rng(seed + 1);
//   auto sched = nn::LrSchedule::warmup_cosine(5e-5, 1000, total_steps, 1e-6);
//   nn::TrainState ts(params, config_json);
//   ts.optimizer(opt).ema(ema).generator("data", data_rng).generator("dropout", drop_rng);
//   if (resume && std::filesystem::exists(path)) ts.load(path);       // throws on any mismatch, changes nothing
//   nn::TrainLog log(dir + "/log.jsonl", ts.step);                    // drops lines newer than the checkpoint
//   nn::ProgressOptions po; po.start = ts.step; nn::Progress bar(total_steps, "train vbb", po);
//   while (ts.step < total_steps) {                                    // ts.step = updates done so far
//     opt.set_lr(sched.at(ts.step)); opt.zero_grad();
//     ag::Variable loss = model_loss(batch(data_rng), drop_rng); loss.backward(); const double l = loss.item();
//     if (!std::isfinite(nn::clip_grad_norm(params, 1.0))) nn::check_finite_grads(params);  // names the bad param
//     opt.step(); ema.update(); log.write({{"step", ts.step + 1}, {"loss", l}, {"lr", opt.lr()}});
//     bar.update(ts.step + 1, {{"loss", l}});
//     if (++ts.step % save_every == 0 || ts.step == total_steps) ts.save(path);
//   }
// (ts.step is the caller's counter; the convention above keeps it equal to opt.step_count().)
//
// File: an nn::Checkpoint (T2MCKPT1, CRC-32C, temp file + fsync + rename) with tensors
//   "model." + NAME, "optim." + ..., "ema." + ... and meta {"format": "t2m-train-state", "version": 1, "step",
//   "epoch", "cursor", "config", "optimizer": KIND, "generators": {NAME: {"seed", "offset"}}, "user": {...}}.
// load() first validates everything (format, config equality, every tensor's presence/shape/dtype, extra model
// tensors, optimizer kind, generator names), and only then copies, so a failed load leaves all state unchanged.
// Errors (t2m::Error, message starts "train state PATH: " or "checkpoint PATH: "): not a train state; config
// mismatch (names the first differing JSON path and both values); a component present in this run but absent in
// the file or the reverse; shape mismatch (names the tensor and both shapes); truncated/corrupted file
// (checksum); a generator registered twice.
#pragma once
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "nn/ema.h"
#include "nn/optim.h"
#include "tensor/rng.h"

namespace t2m::nn {

class TrainState {
 public:
  static constexpr int kVersion = 1;

  TrainState(NamedParams params, nlohmann::json config = nlohmann::json::object());
  TrainState& optimizer(Optimizer& opt);                        // at most one
  TrainState& ema(Ema& ema);                                    // at most one
  TrainState& generator(const std::string& name, Generator& g);  // any number, distinct names

  int64_t step = 0;
  int64_t epoch = 0;
  int64_t cursor = 0;                              // position inside the epoch (samples or batches: caller's choice)
  nlohmann::json user = nlohmann::json::object();  // free-form extra metadata (saved and loaded, not checked)
  const nlohmann::json& config() const { return config_; }

  void save(const std::string& path) const;
  void load(const std::string& path);
  void load(const Checkpoint& ck);  // from an already-read file (ck.source() names it in errors)

 private:
  NamedParams params_;
  nlohmann::json config_;
  Optimizer* opt_ = nullptr;
  Ema* ema_ = nullptr;
  std::vector<std::pair<std::string, Generator*>> gens_;
};

}  // namespace t2m::nn
