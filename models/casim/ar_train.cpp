// ar_train.cpp — batches of code crops with captions, the resumable GPT training loop, teacher-forced evaluation.
#include "models/casim/ar_train.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>

#include "autograd/no_grad.h"
#include "models/data/captions.h"
#include "nn/loss_classification.h"
#include "nn/lr_schedule.h"
#include "nn/optim_adamw.h"
#include "nn/progress.h"
#include "nn/train_log.h"
#include "nn/train_state.h"
#include "nn/train_step.h"
#include "tensor/ops.h"

namespace t2m::casim {

nlohmann::json ArTrainConfig::to_json() const {
  nlohmann::json j = common_json();
  j["corrupt"] = corrupt;
  return j;
}

void ArTrainConfig::validate() const {
  validate_common("ar train", to_json());
  if (!(corrupt >= 0 && corrupt < 1)) throw Error("ar train: bad config " + to_json().dump() + " (0 <= corrupt < 1)");
}

namespace {

// Inputs/targets of crops [start, start + n) of items; `ends[b]`: the crop reaches the item's end.
void fill_codes(const CodeSet& set, const std::vector<int64_t>& item, const std::vector<int64_t>& start,
                const std::vector<int64_t>& len, std::vector<int64_t>& in, std::vector<int64_t>& tgt, int64_t n_max) {
  const int64_t B = (int64_t)item.size();
  in.assign(B * n_max, 0);
  tgt.assign(B * (n_max + 1), -100);
  for (int64_t b = 0; b < B; ++b) {
    const auto& c = set.items[item[b]].codes;
    for (int64_t i = 0; i < len[b]; ++i) in[b * n_max + i] = tgt[b * (n_max + 1) + i] = c[start[b] + i];
    if (start[b] + len[b] == (int64_t)c.size()) tgt[b * (n_max + 1) + len[b]] = set.codes;  // end token
  }
}

}  // namespace

ArBatch make_ar_batch(const CodeSet& set, const ArTextEncoder& text, int64_t batch, int64_t max_motion,
                      double corrupt, Generator& data, Generator& corrupt_rng) {
  if (set.items.empty()) throw Error("ar train: empty code set");
  const std::vector<int64_t> item = randint({batch}, data, 0, (int64_t)set.items.size()).to_vector<int64_t>();
  const std::vector<float> u = rand_uniform({batch}, data).to_vector<float>();
  const std::vector<int64_t> k = randint({batch}, data, 0, int64_t{1} << 31).to_vector<int64_t>();
  std::vector<int64_t> start(batch), len(batch);
  std::vector<std::string> caps(batch);
  int64_t n_max = 1;
  for (int64_t b = 0; b < batch; ++b) {
    const CodeItem& it = set.items[item[b]];
    const int64_t L = (int64_t)it.codes.size();
    len[b] = std::min(L, max_motion);
    start[b] = std::min<int64_t>((int64_t)(u[b] * (double)(L - len[b] + 1)), L - len[b]);
    n_max = std::max(n_max, len[b]);
    caps[b] = data::make_caption(it.content, it.style, 0, (uint64_t)k[b], it.mirrored).text;
  }
  std::vector<int64_t> in, tgt;
  fill_codes(set, item, start, len, in, tgt, n_max);
  // T2M-GPT corruption of the teacher-forced inputs (always drawn, so the rng advances the same way).
  const std::vector<float> cu = rand_uniform({batch, n_max}, corrupt_rng).to_vector<float>();
  const std::vector<int64_t> rc = randint({batch, n_max}, corrupt_rng, 0, set.codes).to_vector<int64_t>();
  for (int64_t b = 0; b < batch; ++b)
    for (int64_t i = 0; i < len[b]; ++i)
      if (cu[b * n_max + i] < corrupt) in[b * n_max + i] = rc[b * n_max + i];
  return {text.encode(caps), Tensor::from_vector(in, {batch, n_max}), Tensor::from_vector(tgt, {batch, n_max + 1})};
}

TrainResult train_ar(ArGpt& model, const CodeSet& set, const ArTextEncoder& text, const ArTrainConfig& cfg,
                     const TrainPaths& paths, bool resume) {
  cfg.validate();
  if (set.items.empty()) throw Error("ar train: empty code set");
  if (set.codes != model.config().codes)
    throw Error("ar train: code set has K = " + std::to_string(set.codes) + ", the model " +
                std::to_string(model.config().codes));
  const auto t0 = std::chrono::steady_clock::now();
  const double c0 = process_cpu_seconds();
  model.train();
  const nn::NamedParams params = model.named_parameters();
  const nn::AdamWOptions ao = cfg.adamw();
  nn::AdamW opt(params, ao);
  Generator data_rng(cfg.seed * 7 + 1), corrupt_rng(cfg.seed * 7 + 2);
  nn::TrainState ts(params, {{"train", cfg.to_json()}, {"model", model.config().to_json()},
                             {"items", set.items.size()}, {"vq_crc", set.vq_crc}});
  ts.optimizer(opt).generator("data", data_rng).generator("corrupt", corrupt_rng);
  if (resume && std::filesystem::exists(paths.state)) ts.load(paths.state);
  const int64_t end = cfg.end_step();
  const auto sched = cfg.lr_schedule();
  nn::TrainLog log(paths.log, ts.step);
  nn::ProgressOptions po;
  po.start = ts.step;
  nn::Progress bar(cfg.steps, std::string("train casim ar-") + ar_cond_name(model.config().cond), po);
  while (ts.step < end) {
    opt.set_lr(sched.at(ts.step));
    opt.zero_grad();
    const ArBatch b = make_ar_batch(set, text, cfg.batch, model.config().max_motion, cfg.corrupt, data_rng,
                                    corrupt_rng);
    const ag::Variable logits = model.forward(b.text, b.inputs);
    ag::Variable loss = nn::cross_entropy(logits, b.targets);  // CASIM Eq 2, teacher forcing
    const auto [l, gn] = nn::backward_clip_step(loss, params, opt);
    const double acc = nn::accuracy(logits.data(), b.targets);
    log.write({{"step", ts.step + 1}, {"loss", l}, {"acc", acc}, {"lr", opt.lr()}, {"grad_norm", gn}});
    bar.update(ts.step + 1, {{"loss", l}, {"acc", acc}});
    if (++ts.step % cfg.save_every == 0 || ts.step == end) ts.save(paths.state);
  }
  bar.finish();
  model.eval();
  nn::write_loss_plot_if_logged(paths.log, paths.svg,
                                std::string("CASIM AR GPT (") + ar_cond_name(model.config().cond) +
                                    "): token cross-entropy (Bandai train split)",
                                {"loss"}, /*log_y=*/false);
  TrainResult r;
  r.steps = ts.step;
  r.final_loss = bar.smoothed("loss");
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.cpu_seconds = process_cpu_seconds() - c0;
  return r;
}

ArEval ar_evaluate(const ArGpt& model, const CodeSet& set, const ArTextEncoder& text, uint64_t caption_seed) {
  ag::NoGradGuard ng;
  std::vector<int64_t> items;
  for (int64_t i = 0; i < (int64_t)set.items.size(); ++i)
    if (!set.items[i].mirrored) items.push_back(i);
  const int64_t M = model.config().max_motion;
  ArEval e;
  double ce_sum = 0, acc_sum = 0;
  for (size_t s = 0; s < items.size(); s += 32) {
    const std::vector<int64_t> it(items.begin() + s, items.begin() + std::min(items.size(), s + 32));
    const int64_t B = (int64_t)it.size();
    std::vector<int64_t> start(B, 0), len(B);
    std::vector<std::string> caps(B);
    int64_t n_max = 1;
    for (int64_t b = 0; b < B; ++b) {
      const CodeItem& c = set.items[it[b]];
      len[b] = std::min<int64_t>((int64_t)c.codes.size(), M);
      n_max = std::max(n_max, len[b]);
      caps[b] = data::make_caption(c.content, c.style, caption_seed, 0).text;
    }
    std::vector<int64_t> in, tgt;
    fill_codes(set, it, start, len, in, tgt, n_max);
    const Tensor targets = Tensor::from_vector(tgt, {B, n_max + 1});
    const ag::Variable logits = model.forward(text.encode(caps), Tensor::from_vector(in, {B, n_max}));
    int64_t n = 0;
    for (int64_t t : tgt) n += t != -100;
    ce_sum += nn::cross_entropy(logits, targets).item() * (double)n;
    acc_sum += nn::accuracy(logits.data(), targets) * (double)n;
    e.targets += n;
    e.items += B;
  }
  e.ce = e.targets ? ce_sum / (double)e.targets : 0;
  e.acc = e.targets ? acc_sum / (double)e.targets : 0;
  return e;
}

}  // namespace t2m::casim
