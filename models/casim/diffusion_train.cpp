// diffusion_train.cpp — the resumable x0-prediction training loop (MDM Eq 2 loss).
#include "models/casim/diffusion_train.h"

#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>

#include "models/casim/diffusion_generate.h"
#include "models/casim/diffusion_schedule.h"
#include "nn/loss_regression.h"
#include "nn/lr_schedule.h"
#include "nn/optim_adamw.h"
#include "nn/progress.h"
#include "nn/train_log.h"
#include "nn/train_state.h"
#include "nn/train_step.h"

namespace t2m::casim {

nlohmann::json DiffusionTrainConfig::to_json() const {
  nlohmann::json j = common_json();
  j["window"] = window, j["mirror_prob"] = mirror_prob, j["paraphrases"] = paraphrases;
  return j;
}

void DiffusionTrainConfig::validate() const {
  validate_common("casim train", to_json());
  if (window < 1 || !(mirror_prob >= 0 && mirror_prob <= 1) || paraphrases < 1)
    throw Error("casim train: bad config " + to_json().dump() + " (window, paraphrases >= 1, mirror_prob in [0, 1])");
}

DiffusionTrainResult train_diffusion(CasimDenoiser& model, const text::RetrievalBundle& tb,
                                     const std::vector<data::MotionClip>& train, const data::FeatureStats& stats,
                                     const DiffusionTrainConfig& cfg, const DiffusionTrainPaths& paths, bool resume,
                                     const std::string& label) {
  cfg.validate();
  if ((int64_t)train.size() < cfg.batch)
    throw Error("casim train: " + std::to_string(train.size()) + " train clips, fewer than one batch of " +
                std::to_string(cfg.batch));
  if (stats.dim() != model.config().feature_dim) throw Error("casim train: feature stats of the wrong size");
  const auto t0 = std::chrono::steady_clock::now();
  const std::clock_t c0 = std::clock();
  const DiffusionSchedule sch = cosine_schedule(model.config().diffusion_steps);

  data::LoaderConfig lc;
  lc.batch_size = (int)cfg.batch, lc.window = (int)cfg.window, lc.mirror_prob = cfg.mirror_prob;
  lc.paraphrases = cfg.paraphrases, lc.seed = cfg.seed, lc.drop_last = true;
  data::MotionLoader loader(&train, stats, lc);

  model.train();
  const nn::NamedParams params = model.named_parameters();
  const nn::AdamWOptions ao = cfg.adamw();
  nn::AdamW opt(params, ao);
  Generator diff_rng(cfg.seed * 3 + 21), drop_rng(cfg.seed * 3 + 22);
  const nlohmann::json config = {{"model", model.config().to_json()}, {"train", cfg.to_json()},
                                 {"clips", (int64_t)train.size()}};
  nn::TrainState ts(params, config);
  ts.optimizer(opt).generator("diffusion", diff_rng).generator("drop", drop_rng);
  if (resume && std::filesystem::exists(paths.state)) ts.load(paths.state);
  const int64_t end = cfg.end_step();
  const auto sched = cfg.lr_schedule();
  nn::TrainLog log(paths.log, ts.step);

  loader.start_epoch(ts.epoch);
  data::Batch batch;
  for (int64_t i = 0; i < ts.cursor; ++i)
    if (!loader.next(batch)) throw Error("casim train: resume cursor past the end of the epoch");

  nn::ProgressOptions po;
  po.start = ts.step;
  nn::Progress bar(cfg.steps, label, po);
  while (ts.step < end) {
    if (!loader.next(batch)) {
      ++ts.epoch, ts.cursor = 0;
      loader.start_epoch(ts.epoch);
      if (!loader.next(batch)) throw Error("casim train: empty epoch");
    }
    ++ts.cursor;
    const DiffusionText text = encode_diffusion_text(tb, batch.captions);
    const int64_t B = batch.x.size(0);
    opt.set_lr(sched.at(ts.step));
    opt.zero_grad();
    const Tensor t = randint({B}, diff_rng, 0, sch.steps);
    const Tensor eps = rand_normal(batch.x.shape(), diff_rng);
    const Tensor x_t = q_sample(sch, batch.x, t, eps);  // CASIM Eq 3 forward process
    const Tensor drop = model.sample_condition_drop(B, drop_rng);
    const ag::Variable x0 = model.forward(ag::Variable(x_t), t, text, drop, batch.mask);
    nn::MseOptions mo;
    mo.weights = batch.mask.unsqueeze(2);
    ag::Variable loss = nn::mse_loss(x0, ag::Variable(batch.x), mo);  // MDM Eq 2 (simple x0 loss)
    const auto [l, gn] = nn::backward_clip_step(loss, params, opt);
    log.write({{"step", ts.step + 1}, {"loss", l}, {"lr", opt.lr()}, {"grad_norm", gn}});
    bar.update(ts.step + 1, {{"loss", l}});
    if (++ts.step % cfg.save_every == 0 || ts.step == end) ts.save(paths.state);
  }
  bar.finish();
  model.eval();
  nn::write_loss_plot_if_logged(paths.log, paths.svg, label + ": x0 loss (Bandai train split, normalised features)");
  DiffusionTrainResult r;
  r.steps = ts.step;
  r.final_loss = bar.smoothed("loss");
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.cpu_seconds = double(std::clock() - c0) / CLOCKS_PER_SEC;
  return r;
}

}  // namespace t2m::casim
