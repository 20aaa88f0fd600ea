// gen_train.cpp — the resumable flow-matching training loop of the generator.
#include "models/text2bfm/gen_train.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>

#include "nn/ema.h"
#include "nn/loss_diffusion.h"
#include "nn/loss_flow.h"
#include "nn/lr_schedule.h"
#include "nn/optim_adamw.h"
#include "nn/progress.h"
#include "nn/train_log.h"
#include "nn/train_state.h"
#include "nn/train_step.h"
#include "tensor/ops.h"

namespace t2m::text2bfm {

nlohmann::json GenTrainConfig::to_json() const {
  nlohmann::json j = common_json();
  if (objective != "flow") j["objective"] = objective, j["schedule"] = schedule;
  if (ema > 0) j["ema"] = ema;
  return j;
}

void GenTrainConfig::validate() const {
  validate_common("gen train", to_json());
  if (objective != "flow" && objective != "diffusion")
    throw Error("gen train: objective must be flow or diffusion, got '" + objective + "'");
  nn::noise_schedule_from_name(schedule);
  if (!(ema >= 0 && ema < 1)) throw Error("gen train: ema must be in [0, 1), got " + std::to_string(ema));
}

GenTrainResult train_generator(FlowGenerator& gen, const ProgramDataset& data, const GenTrainConfig& cfg,
                               const GenTrainPaths& paths, bool resume, const std::string& label) {
  cfg.validate();
  const auto t0 = std::chrono::steady_clock::now();
  gen.train();
  const nn::NamedParams params = gen.named_parameters();
  const nn::AdamWOptions ao = cfg.adamw();
  nn::AdamW opt(params, ao);
  Generator data_rng(cfg.seed * 3 + 11), flow_rng(cfg.seed * 3 + 12), drop_rng(cfg.seed * 3 + 13);
  const nlohmann::json config = {{"train", cfg.to_json()}, {"window", data.window},
                                 {"clips", (int64_t)data.programs.size()}, {"captions", data.tokens.size(0)}};
  nn::TrainState ts(params, config);
  ts.optimizer(opt).generator("data", data_rng).generator("flow", flow_rng).generator("drop", drop_rng);
  std::unique_ptr<nn::Ema> ema;
  if (cfg.ema > 0) {
    ema = std::make_unique<nn::Ema>(params, cfg.ema, /*warmup=*/true);
    ts.ema(*ema);
  }
  if (resume && std::filesystem::exists(paths.state)) ts.load(paths.state);
  const int64_t end = cfg.end_step();
  const auto sched = cfg.lr_schedule();
  nn::TrainLog log(paths.log, ts.step);
  nn::ProgressOptions po;
  po.start = ts.step;
  nn::Progress bar(cfg.steps, label, po);
  const bool diffusion = cfg.objective == "diffusion";
  const nn::NoiseSchedule schedule = nn::noise_schedule_from_name(cfg.schedule);
  while (ts.step < end) {
    opt.set_lr(sched.at(ts.step));
    opt.zero_grad();
    const ProgramBatch b = sample_program_batch(data, cfg.batch, data_rng);
    nn::MseOptions mo;
    mo.weights = b.m_mask.unsqueeze(2);
    ag::Variable loss;
    if (diffusion) {  // v-prediction (Table 5's diffusion variant)
      const nn::DiffusionSample ds = nn::sample_diffusion_pair(b.m, flow_rng, schedule);
      const Tensor drop = gen.sample_condition_drop(cfg.batch, drop_rng);
      const ag::Variable v = gen.forward(ag::Variable(ds.x_t), t2m::add(t2m::neg(ds.t), 1.0), ag::Variable(b.tokens),
                                         b.tok_mask, drop, b.m_mask);
      loss = nn::diffusion_v_loss(v, ag::Variable(b.m), ag::Variable(ds.eps), ag::Variable(ds.alpha),
                                  ag::Variable(ds.sigma), mo);
    } else {
      const nn::FlowSample fsmp = nn::sample_flow_pair(b.m, flow_rng);           // Eq 14
      const Tensor drop = gen.sample_condition_drop(cfg.batch, drop_rng);
      const ag::Variable v = gen.forward(ag::Variable(fsmp.x_t), fsmp.t, ag::Variable(b.tokens), b.tok_mask, drop,
                                         b.m_mask);
      loss = nn::flow_matching_loss(v, ag::Variable(fsmp.x0), ag::Variable(b.m), mo);  // Eq 15
    }
    const auto [l, gn] = nn::backward_clip_step(loss, params, opt);
    if (ema) ema->update();
    log.write({{"step", ts.step + 1}, {"loss", l}, {"lr", opt.lr()}, {"grad_norm", gn}});
    bar.update(ts.step + 1, {{"loss", l}});
    if (++ts.step % cfg.save_every == 0 || ts.step == end) ts.save(paths.state);
  }
  bar.finish();
  gen.eval();
  if (ema) ema->apply();  // the averaged weights stay in the generator (the training values are in the state)
  nn::write_loss_plot_if_logged(paths.log, paths.svg,
                                diffusion ? "diffusion generator: v-prediction loss (train split programs)"
                                          : "flow generator: Eq 15 loss (train split programs)");
  GenTrainResult r;
  r.steps = ts.step;
  r.final_loss = bar.smoothed("loss");
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace t2m::text2bfm
