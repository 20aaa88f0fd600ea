// vq_train.cpp — the resumable tokenizer training loop and the test-split evaluation.
#include "models/casim/vq_train.h"

#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>

#include "autograd/no_grad.h"
#include "models/data/features.h"
#include "nn/lr_schedule.h"
#include "nn/optim_adamw.h"
#include "nn/progress.h"
#include "nn/train_log.h"
#include "nn/train_state.h"
#include "nn/train_step.h"
#include "tensor/ops.h"

namespace t2m::casim {

double process_cpu_seconds() { return (double)std::clock() / CLOCKS_PER_SEC; }

nlohmann::json VqTrainConfig::to_json() const {
  nlohmann::json j = common_json();
  j["window"] = window;
  return j;
}

void VqTrainConfig::validate() const {
  validate_common("vq train", to_json());
  if (window < 4 || window % 4 != 0)
    throw Error("vq train: bad config " + to_json().dump() + " (window a positive multiple of 4)");
}

TrainResult train_vq(VqVae& model, const std::vector<data::MotionClip>& train, const data::FeatureStats& stats,
                     const VqTrainConfig& cfg, const TrainPaths& paths, bool resume) {
  cfg.validate();
  if (train.empty()) throw Error("vq train: no training clips");
  const auto t0 = std::chrono::steady_clock::now();
  const double c0 = process_cpu_seconds();
  model.train();
  const nn::NamedParams trainable = model.trainable_parameters();
  const nn::AdamWOptions ao = cfg.adamw();
  nn::AdamW opt(trainable, ao);
  Generator reset_rng(cfg.seed * 5 + 3);
  nn::TrainState ts(model.named_parameters(),
                    {{"train", cfg.to_json()}, {"model", model.config().to_json()}, {"clips", train.size()}});
  ts.optimizer(opt).generator("reset", reset_rng);
  if (resume && std::filesystem::exists(paths.state)) ts.load(paths.state);

  data::LoaderConfig lc;
  lc.batch_size = (int)cfg.batch, lc.window = (int)cfg.window, lc.seed = cfg.seed, lc.drop_last = true;
  data::MotionLoader loader(&train, stats, lc);
  if (loader.batches_per_epoch() < 1) throw Error("vq train: fewer clips than one batch");
  loader.start_epoch(ts.epoch);
  data::Batch batch;
  for (int64_t i = 0; i < ts.cursor; ++i) loader.next(batch);  // skip what the resumed run already used

  const int64_t end = cfg.end_step();
  const auto sched = cfg.lr_schedule();
  nn::TrainLog log(paths.log, ts.step);
  nn::ProgressOptions po;
  po.start = ts.step;
  nn::Progress bar(cfg.steps, "train casim vq", po);
  while (ts.step < end) {
    if (!loader.next(batch)) {
      loader.start_epoch(++ts.epoch);
      ts.cursor = 0;
      loader.next(batch);
    }
    ++ts.cursor;
    opt.set_lr(sched.at(ts.step));
    opt.zero_grad();
    VqStep s = vq_loss(model, batch.x, batch.mask);
    const auto [l, gn] = nn::backward_clip_step(s.loss, trainable, opt);
    const int64_t resets = model.codebook().ema_update(s.z_real, s.ids_real, reset_rng);
    log.write({{"step", ts.step + 1}, {"loss", l}, {"rec", s.rec}, {"vel", s.vel}, {"commit", s.commit},
               {"resets", resets}, {"lr", opt.lr()}, {"grad_norm", gn}});
    bar.update(ts.step + 1, {{"loss", l}, {"rec", s.rec}, {"resets", (double)resets}});
    if (++ts.step % cfg.save_every == 0 || ts.step == end) ts.save(paths.state);
  }
  bar.finish();
  model.eval();
  nn::write_loss_plot_if_logged(paths.log, paths.svg, "CASIM AR tokenizer: VQ-VAE loss (Bandai train split)",
                                {"loss", "rec", "vel", "commit"});
  TrainResult r;
  r.steps = ts.step;
  r.final_loss = bar.smoothed("loss");
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.cpu_seconds = process_cpu_seconds() - c0;
  return r;
}

nlohmann::json VqEval::to_json() const {
  return {{"rec_mse_normalised", rec_mse}, {"mpjpe_m", mpjpe_m}, {"codes_used", used}, {"codes", codes},
          {"perplexity", perplexity},      {"tokens", tokens},   {"clips", clips}};
}

VqEval vq_evaluate(const VqVae& model, const std::vector<data::MotionClip>& clips, const data::FeatureStats& stats) {
  const int64_t D = model.config().feature_dim, f = model.config().downsample();
  const int64_t K = model.config().codebook.codes;
  VqEval e;
  e.codes = K;
  std::vector<int64_t> counts(K, 0);
  double se = 0, ne = 0, pe = 0, np = 0;
  for (const auto& c : clips) {
    const int64_t T = (c.frames / f) * f;
    if (T < f) continue;
    std::vector<float> x(c.features.begin(), c.features.begin() + T * D);
    data::normalize_features(x, stats);
    const Tensor ids = model.tokenize(Tensor::from_vector(x, {1, T, D}));
    const std::vector<float> y = model.detokenize(ids).to_vector<float>();
    for (int64_t i = 0; i < T * D; ++i) se += (double)(y[i] - x[i]) * (y[i] - x[i]);
    ne += (double)(T * D);
    for (int64_t v : ids.to_vector<int64_t>()) ++counts[v], ++e.tokens;
    std::vector<float> yr = y, xr(c.features.begin(), c.features.begin() + T * D);
    data::denormalize_features(yr, stats);
    const std::vector<float> pa = data::features_to_positions(xr), pb = data::features_to_positions(yr);
    const size_t J = data::kFeatureJoints;
    for (size_t t = 0; t < (size_t)T; ++t)
      for (size_t j = 0; j < J; ++j) {  // root-relative: joint minus the frame's root (joint 0)
        double d2 = 0;
        for (size_t a = 0; a < 3; ++a) {
          const size_t i = (t * J + j) * 3 + a, r = t * J * 3 + a;
          d2 += std::pow((double)(pa[i] - pa[r]) - (pb[i] - pb[r]), 2);
        }
        pe += std::sqrt(d2), np += 1;
      }
    ++e.clips;
  }
  e.rec_mse = ne > 0 ? se / ne : 0;
  e.mpjpe_m = np > 0 ? pe / np : 0;
  for (int64_t c : counts) e.used += c > 0;
  e.perplexity = code_perplexity(counts);
  return e;
}

}  // namespace t2m::casim
