// retrieval_train.cpp — the contrastive training loop (symmetric InfoNCE) and retrieval scores of a pair.
#include "models/text/retrieval_train.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>

#include "models/data/captions.h"
#include "nn/loss_contrastive.h"
#include "nn/lr_schedule.h"
#include "nn/optim_adamw.h"
#include "nn/progress.h"
#include "nn/train_log.h"
#include "nn/train_state.h"
#include "nn/train_step.h"

namespace t2m::text {

namespace {

// Label key of a batch item: mirrored items swap left/right in the content label (walk-turn-left -> ...-right).
std::string label_key(const data::MotionClip& c, bool mirrored) {
  if (!c.caption.empty()) return "caption:" + (mirrored ? data::swap_left_right(c.caption) : c.caption);
  const std::string content = mirrored ? data::swap_left_right(c.content) : c.content;
  return content + "|" + c.style;
}

// (B,) int64 ids: equal for equal label keys (the false negatives info_nce leaves out).
Tensor text_ids(const data::Batch& b, const std::vector<data::MotionClip>& clips) {
  std::map<std::string, int64_t> ids;
  std::vector<int64_t> out(b.size());
  for (int i = 0; i < b.size(); ++i) {
    auto it = ids.emplace(label_key(clips[b.clip[i]], b.mirrored[i] != 0), (int64_t)ids.size()).first;
    out[i] = it->second;
  }
  return Tensor::from_vector(out, {(int64_t)out.size()});
}

std::vector<double> top_values(const eval::RPrecision& r) { return r.top; }

}  // namespace

nlohmann::json RetrievalTrainConfig::to_json() const {
  return {{"steps", steps},
          {"batch", batch},
          {"lr", lr},
          {"weight_decay", weight_decay},
          {"warmup", warmup},
          {"mirror_prob", mirror_prob},
          {"seed", seed},
          {"save_every", save_every},
          {"eval_every", eval_every}};
}

nlohmann::json RetrievalScores::to_json() const {
  nlohmann::json j = {{"clips", clips}};
  for (size_t k = 0; k < top.size(); ++k) {
    j["r_precision_top" + std::to_string(k + 1)] = {{"mean", top[k].mean}, {"ci95", top[k].ci95}};
    j["control_r_precision_top" + std::to_string(k + 1)] = {{"mean", control[k].mean}, {"ci95", control[k].ci95}};
  }
  return j;
}

RetrievalScores retrieval_r_precision(const RetrievalBundle& bundle, const std::vector<data::MotionClip>& clips,
                                      uint64_t caption_seed, int runs, uint64_t seed) {
  std::vector<std::string> caps;
  std::vector<const std::vector<float>*> feats;
  for (const auto& c : clips) {
    caps.push_back(c.caption.empty() ? data::make_caption(c.content, c.style, caption_seed, 0).text : c.caption);
    feats.push_back(&c.features);
  }
  const Tensor t = embed_texts(bundle, caps), m = embed_motions(bundle, feats);
  RetrievalScores s;
  s.clips = (int64_t)clips.size();
  s.top = eval::repeat_runs(runs, seed, [&](Generator& g, int) { return top_values(eval::r_precision(t, m, g)); });
  s.control = eval::repeat_runs(runs, seed ^ 0xC0C0,
                                [&](Generator& g, int) { return top_values(eval::shuffled_r_precision(t, m, g)); });
  return s;
}

RetrievalTrainResult train_retrieval(RetrievalBundle& bundle, const std::vector<data::MotionClip>& train,
                                     const std::vector<data::MotionClip>& val, const RetrievalTrainConfig& cfg,
                                     const RetrievalTrainPaths& paths, bool resume, const std::string& label) {
  if (!bundle.model) throw Error("train_retrieval: no model");
  RetrievalModel& model = *bundle.model;
  if (bundle.stats.dim() != model.feature_dim())
    throw Error("train_retrieval: feature stats have " + std::to_string(bundle.stats.dim()) + " dims, the model " +
                std::to_string(model.feature_dim()));
  if (cfg.steps < 1 || cfg.batch < 2 || !(cfg.lr > 0) || cfg.warmup < 0 || cfg.save_every < 1 || cfg.eval_every < 0)
    throw Error("train_retrieval: bad config " + cfg.to_json().dump());
  if (bundle.window < 1 || bundle.window > model.max_frames())
    throw Error("train_retrieval: window " + std::to_string(bundle.window) +
                " outside [1, max_frames = " + std::to_string(model.max_frames()) + "]");
  if ((int64_t)train.size() < cfg.batch)
    throw Error("train_retrieval: " + std::to_string(train.size()) + " train clips, fewer than one batch of " +
                std::to_string(cfg.batch));

  data::LoaderConfig lc;
  lc.batch_size = cfg.batch, lc.window = (int)bundle.window, lc.mirror_prob = cfg.mirror_prob;
  lc.paraphrases = 0, lc.seed = cfg.seed, lc.drop_last = true;
  data::MotionLoader loader(&train, bundle.stats, lc);

  nn::NamedParams params = model.named_parameters();
  ag::Variable alpha = ag::Variable::parameter(Tensor::full({1}, nn::kInitLogitScale), "logit_scale");
  params.emplace_back("logit_scale", alpha);
  nn::AdamWOptions ao;
  ao.lr = cfg.lr, ao.weight_decay = cfg.weight_decay, ao.no_decay = nn::no_decay_1d;
  nn::AdamW opt(params, ao);
  const auto sched = nn::LrSchedule::warmup_cosine(cfg.lr, std::min(cfg.warmup, cfg.steps - 1), cfg.steps, cfg.lr / 10);
  nlohmann::json config = {
      {"kind", model.kind()},    {"model", model.config_json()},           {"train", cfg.to_json()},
      {"window", bundle.window}, {"vocab", bundle.tokenizer.vocab_size()}, {"train_clips", train.size()}};
  nn::TrainState ts(params, config);
  ts.optimizer(opt);
  if (resume && std::filesystem::exists(paths.state)) ts.load(paths.state);
  nn::TrainLog log(paths.log, ts.step);

  loader.start_epoch(ts.epoch);
  data::Batch batch;
  for (int64_t i = 0; i < ts.cursor; ++i)
    if (!loader.next(batch)) throw Error("train_retrieval: resume cursor past the end of the epoch");

  nn::ProgressOptions po;
  po.start = ts.step;
  nn::Progress bar(cfg.steps, label, po);
  const auto t0 = std::chrono::steady_clock::now();
  RetrievalTrainResult res;
  res.final_loss = NAN;
  model.train();
  const int64_t end = cfg.stop_at > 0 ? std::min(cfg.stop_at, cfg.steps) : cfg.steps;
  while (ts.step < end) {
    if (!loader.next(batch)) {
      ++ts.epoch, ts.cursor = 0;
      loader.start_epoch(ts.epoch);
      if (!loader.next(batch)) throw Error("train_retrieval: empty epoch");
    }
    ++ts.cursor;
    const EncodedBatch eb = encode_captions(bundle.tokenizer, batch.captions, model.max_text_len());
    opt.set_lr(sched.at(ts.step));
    opt.zero_grad();
    const ag::Variable et = model.embed_text(eb.ids, eb.mask);
    const ag::Variable em = model.embed_motion(ag::Variable(batch.x), batch.mask);
    const nn::ContrastiveLoss cl = nn::info_nce(em, et, alpha, text_ids(batch, train));
    const auto [loss, gn] = nn::backward_clip_step(cl.loss, params, opt);
    nn::clamp_logit_scale_(alpha);
    ++ts.step;
    nlohmann::json rec = {{"step", ts.step},
                          {"loss", loss},
                          {"lr", opt.lr()},
                          {"logit_scale", std::exp(alpha.data().item())},
                          {"grad_norm", gn}};
    if (cfg.eval_every > 0 && !val.empty() && (ts.step % cfg.eval_every == 0 || ts.step == cfg.steps) &&
        (int64_t)val.size() >= 32) {
      const RetrievalScores s = retrieval_r_precision(bundle, val, cfg.seed, 5, 0);
      model.train();
      for (size_t k = 0; k < s.top.size(); ++k) rec["val_top" + std::to_string(k + 1)] = s.top[k].mean;
    }
    log.write(rec);
    bar.update(ts.step, {{"loss", loss}, {"scale", std::exp(alpha.data().item())}});
    res.final_loss = bar.smoothed("loss");
    if (ts.step % cfg.save_every == 0 || ts.step == end) ts.save(paths.state);
  }
  bar.finish();
  model.eval();
  if (!paths.svg.empty()) {
    nn::SvgPlotOptions so;
    so.keys = {"loss"};
    so.title = label + " (InfoNCE loss, train split)";
    write_loss_svg(paths.log, paths.svg, so);
  }
  res.steps = ts.step;
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

}  // namespace t2m::text
