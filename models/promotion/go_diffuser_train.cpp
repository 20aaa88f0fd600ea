// go_diffuser_train.cpp — the resumable DDPM training loop of the go-diffuser.
#include "models/promotion/go_diffuser_train.h"

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>

#include "models/promotion/pose.h"
#include "nn/lr_schedule.h"
#include "nn/optim_adamw.h"
#include "nn/progress.h"
#include "nn/train_log.h"
#include "nn/train_state.h"
#include "nn/train_step.h"

namespace t2m::promotion {

void batch_key_poses(const Tensor& x, const std::vector<int>& lengths, int64_t K, Tensor* keys, Tensor* key_frames) {
  const int64_t B = x.size(0), T = x.size(1), D = x.size(2);
  if ((int64_t)lengths.size() != B || D != data::kFeatureDim)
    throw Error("go train: batch_key_poses needs x (B, T, 257) and B lengths, got " + shape_str(x.shape()) + " and " +
                std::to_string(lengths.size()));
  const Tensor xc = x.to(DType::f32).contiguous();
  const float* px = xc.data<float>();
  std::vector<float> kp((size_t)(B * K * kPoseDim));
  std::vector<int64_t> kf((size_t)(B * K));
  for (int64_t b = 0; b < B; ++b) {
    const int len = std::max(1, std::min<int>(lengths[b], (int)T));
    const std::vector<int> f = key_frame_indices(len, (int)K);
    for (int64_t i = 0; i < K; ++i) {
      kf[b * K + i] = f[i];
      pose_from_features(px + (b * T + f[i]) * D, kp.data() + (b * K + i) * kPoseDim);
    }
  }
  *keys = Tensor::from_vector(kp, {B, K, kPoseDim});
  *key_frames = Tensor::from_vector(kf, {B, K});
}

GoTrainResult train_go_diffuser(GoDiffuser& m, const std::vector<data::MotionClip>& clips,
                                const data::FeatureStats& stats, const GoTrainConfig& cfg, const GoTrainPaths& paths,
                                bool resume, const std::string& label) {
  cfg.validate();
  if (clips.empty()) throw Error("go train: no training clips");
  const auto t0 = std::chrono::steady_clock::now();
  m.train();
  const nn::NamedParams params = m.named_parameters();
  const nn::AdamWOptions ao = cfg.adamw();
  nn::AdamW opt(params, ao);
  Generator noise_rng(cfg.seed * 3 + 21), drop_rng(cfg.seed * 3 + 22);
  data::LoaderConfig lc;
  lc.batch_size = (int)cfg.batch;
  lc.window = (int)m.config().frames;
  lc.seed = cfg.seed;
  lc.drop_last = true;
  data::MotionLoader loader(&clips, stats, lc);
  const nlohmann::json config = {{"train", cfg.to_json()}, {"model", m.config().to_json()},
                                 {"clips", (int64_t)clips.size()}};
  nn::TrainState ts(params, config);
  ts.optimizer(opt).generator("noise", noise_rng).generator("drop", drop_rng);
  if (resume && std::filesystem::exists(paths.state)) ts.load(paths.state);
  loader.start_epoch(ts.epoch);
  data::Batch b;
  for (int64_t i = 0; i < ts.cursor; ++i) loader.next(b);  // replay the epoch up to the saved position
  const int64_t end = cfg.end_step();
  const auto sched = cfg.lr_schedule();
  nn::TrainLog log(paths.log, ts.step);
  nn::ProgressOptions po;
  po.start = ts.step;
  nn::Progress bar(cfg.steps, label, po);
  while (ts.step < end) {
    if (!loader.next(b)) {
      loader.start_epoch(++ts.epoch);
      ts.cursor = 0;
      if (!loader.next(b)) throw Error("go train: fewer clips than one batch (" + std::to_string(clips.size()) + ")");
    }
    ++ts.cursor;
    opt.set_lr(sched.at(ts.step));
    opt.zero_grad();
    Tensor keys, key_frames;
    batch_key_poses(b.x, b.length, m.config().keys, &keys, &key_frames);
    const Tensor t = m.schedule().sample_steps(b.size(), noise_rng);
    const Tensor eps = rand_normal(b.x.shape(), noise_rng);
    const Tensor keep = m.sample_key_keep(b.size(), drop_rng);
    ag::Variable loss = go_diffuser_loss(m, b.x, b.mask, t, eps, keys, key_frames, keep);
    const auto [l, gn] = nn::backward_clip_step(loss, params, opt);
    log.write({{"step", ts.step + 1}, {"loss", l}, {"lr", opt.lr()}, {"grad_norm", gn}});
    bar.update(ts.step + 1, {{"loss", l}});
    if (++ts.step % cfg.save_every == 0 || ts.step == end) ts.save(paths.state);
  }
  bar.finish();
  m.eval();
  nn::write_loss_plot_if_logged(paths.log, paths.svg, "go-diffuser: x0 DDPM loss (train split windows)");
  GoTrainResult r;
  r.steps = ts.step;
  r.final_loss = bar.smoothed("loss");
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace t2m::promotion
