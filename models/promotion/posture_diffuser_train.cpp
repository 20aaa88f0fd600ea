// posture_diffuser_train.cpp — the resumable x_0-prediction DDPM loop of the posture diffuser.
#include "models/promotion/posture_diffuser_train.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>

#include "autograd/no_grad.h"
#include "models/promotion/diffusion_schedule.h"
#include "nn/loss_regression.h"
#include "nn/lr_schedule.h"
#include "nn/optim_adamw.h"
#include "nn/progress.h"
#include "nn/train_log.h"
#include "nn/train_state.h"
#include "nn/train_step.h"
#include "tensor/ops.h"
#include "tensor/rng.h"

namespace t2m::promotion {

PostureTrainData make_posture_train_data(const PostureScriptSet& s, const PoseStats& stats,
                                         const text::Tokenizer& tok, int64_t max_tokens) {
  if (s.size() == 0) throw Error("posture train: the posture-script set is empty");
  std::vector<float> p = s.poses;
  normalize_poses(p, stats);
  PostureTrainData d;
  d.x0 = Tensor::from_vector(p, {(int64_t)s.size(), kPoseDim});
  const text::EncodedBatch e = tok.encode_batch(s.scripts, max_tokens);
  d.ids = e.ids;
  d.mask = e.mask;
  return d;
}

namespace {

DiffusionSchedule schedule_of(const PostureDiffuser& net) {
  const auto& c = net.config();
  return DiffusionSchedule::linear((int)c.diffusion_steps, c.beta_start, c.beta_end);
}

}  // namespace

PostureTrainResult train_posture_diffuser(PostureDiffuser& net, const PostureTrainData& data,
                                          const PostureTrainConfig& cfg, const PostureTrainPaths& paths, bool resume) {
  cfg.validate();
  if (data.size() < 1) throw Error("posture train: no training items");
  const auto t0 = std::chrono::steady_clock::now();
  net.train();
  const DiffusionSchedule sched = schedule_of(net);
  const nn::NamedParams params = net.named_parameters();
  const nn::AdamWOptions ao = cfg.adamw();
  nn::AdamW opt(params, ao);
  Generator data_rng(cfg.seed * 3 + 21), noise_rng(cfg.seed * 3 + 22), drop_rng(cfg.seed * 3 + 23);
  const nlohmann::json config = {{"train", cfg.to_json()}, {"model", net.config().to_json()}, {"items", data.size()}};
  nn::TrainState ts(params, config);
  ts.optimizer(opt).generator("data", data_rng).generator("noise", noise_rng).generator("drop", drop_rng);
  if (resume && std::filesystem::exists(paths.state)) ts.load(paths.state);
  const int64_t end = cfg.end_step();
  const auto lr = cfg.lr_schedule();
  nn::TrainLog log(paths.log, ts.step);
  nn::ProgressOptions po;
  po.start = ts.step;
  nn::Progress bar(cfg.steps, "train promotion posture", po);
  while (ts.step < end) {
    opt.set_lr(lr.at(ts.step));
    opt.zero_grad();
    const Tensor idx = randint({cfg.batch}, data_rng, 0, data.size());
    const Tensor x0 = index_select(data.x0, 0, idx);
    const Tensor t = sched.sample_steps(cfg.batch, noise_rng);
    const Tensor eps = rand_normal({cfg.batch, kPoseDim}, noise_rng);
    const Tensor x_t = sched.q_sample(x0, t, eps);  // DDPM Eq 4
    const Tensor drop = lt(rand_uniform({cfg.batch}, drop_rng), net.config().cond_drop);
    const ScriptContext ctx =
        net.encode_with_drop(index_select(data.ids, 0, idx), index_select(data.mask, 0, idx), drop);
    ag::Variable loss = nn::mse_loss(net.forward(ag::Variable(x_t), t, ctx), ag::Variable(x0));  // paper Eq 2
    const auto [l, gn] = nn::backward_clip_step(loss, params, opt);
    log.write({{"step", ts.step + 1}, {"loss", l}, {"lr", opt.lr()}, {"grad_norm", gn}});
    bar.update(ts.step + 1, {{"loss", l}});
    if (++ts.step % cfg.save_every == 0 || ts.step == end) ts.save(paths.state);
  }
  bar.finish();
  net.eval();
  nn::write_loss_plot_if_logged(paths.log, paths.svg, "posture diffuser: x0 MSE (paper Eq 2), train split key poses");
  PostureTrainResult r;
  r.steps = ts.step;
  r.final_loss = bar.smoothed("loss");
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

double posture_eval_loss(const PostureDiffuser& net, const PostureTrainData& data, int64_t max_items, uint64_t seed,
                         int64_t batch) {
  const int64_t N = std::min(max_items, data.size());
  if (N < 1 || batch < 1) throw Error("posture train: eval needs >= 1 item and batch >= 1");
  ag::NoGradGuard ng;
  const DiffusionSchedule sched = schedule_of(net);
  Generator g(seed);
  const Tensor t_all = sched.sample_steps(N, g);
  const Tensor eps_all = rand_normal({N, kPoseDim}, g);
  double sum = 0;
  for (int64_t b0 = 0; b0 < N; b0 += batch) {
    const int64_t n = std::min(batch, N - b0);
    const Tensor x0 = data.x0.narrow(0, b0, n).contiguous();
    const Tensor t = t_all.narrow(0, b0, n).contiguous();
    const Tensor x_t = sched.q_sample(x0, t, eps_all.narrow(0, b0, n).contiguous());
    const ScriptContext ctx =
        net.encode(data.ids.narrow(0, b0, n).contiguous(), data.mask.narrow(0, b0, n).contiguous());
    sum += nn::mse_loss(net.forward(ag::Variable(x_t), t, ctx), ag::Variable(x0)).item() * (double)n;
  }
  return sum / (double)N;
}

}  // namespace t2m::promotion
