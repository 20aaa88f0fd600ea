// pose_text_encoders_train.cpp — InfoNCE training loop and group retrieval of the posture-planning encoders.
#include "models/promotion/pose_text_encoders_train.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>

#include "autograd/no_grad.h"
#include "models/text/retrieval_model.h"
#include "nn/loss_contrastive.h"
#include "nn/lr_schedule.h"
#include "nn/optim_adamw.h"
#include "nn/progress.h"
#include "nn/train_log.h"
#include "nn/train_state.h"
#include "nn/train_step.h"
#include "tensor/ops.h"

namespace t2m::promotion {

namespace {

// Normalised poses (n, 187) of the items idx.
Tensor batch_poses(const PostureScriptSet& set, const std::vector<int64_t>& idx, const PoseStats& stats) {
  std::vector<float> p;
  p.reserve(idx.size() * kPoseDim);
  for (int64_t i : idx) p.insert(p.end(), set.pose((int)i), set.pose((int)i) + kPoseDim);
  normalize_poses(p, stats);
  return Tensor::from_vector(p, {(int64_t)idx.size(), kPoseDim});
}

}  // namespace

EncodersTrainResult train_pose_text_encoders(PoseTextEncoders& m, const text::Tokenizer& tok,
                                             const PostureScriptSet& set, const PoseStats& stats,
                                             const EncodersTrainConfig& cfg, const EncodersTrainPaths& paths,
                                             bool resume, const std::string& label) {
  cfg.validate();
  if (set.size() < 2) throw Error("encoders train: the posture-script set has " + std::to_string(set.size()) +
                                  " items (need >= 2)");
  const auto t0 = std::chrono::steady_clock::now();
  // Script ids: equal texts share an id (false negatives in InfoNCE).
  std::map<std::string, int64_t> sid;
  std::vector<int64_t> item_sid(set.size());
  for (int i = 0; i < set.size(); ++i) item_sid[i] = sid.emplace(set.scripts[i], (int64_t)sid.size()).first->second;
  m.train();
  const nn::NamedParams params = m.named_parameters();
  const nn::AdamWOptions ao = cfg.adamw();
  nn::AdamW opt(params, ao);
  Generator data_rng(cfg.seed * 5 + 31);
  const nlohmann::json config = {{"train", cfg.to_json()}, {"model", m.config().to_json()}, {"items", set.size()}};
  nn::TrainState ts(params, config);
  ts.optimizer(opt).generator("data", data_rng);
  if (resume && std::filesystem::exists(paths.state)) ts.load(paths.state);
  const int64_t end = cfg.end_step();
  const auto sched = cfg.lr_schedule();
  nn::TrainLog log(paths.log, ts.step);
  nn::ProgressOptions po;
  po.start = ts.step;
  nn::Progress bar(cfg.steps, label, po);
  while (ts.step < end) {
    opt.set_lr(sched.at(ts.step));
    opt.zero_grad();
    const auto idx = randint({cfg.batch}, data_rng, 0, set.size()).to_vector<int64_t>();
    std::vector<std::string> texts;
    std::vector<int64_t> ids;
    for (int64_t i : idx) texts.push_back(set.scripts[i]), ids.push_back(item_sid[i]);
    const auto eb = text::encode_captions(tok, texts, m.config().max_tokens);
    const ag::Variable pe = m.embed_poses(ag::Variable(batch_poses(set, idx, stats)));
    const ag::Variable te = m.embed_scripts(eb.ids, eb.mask);
    const auto cl = nn::info_nce(pe, te, m.logit_scale(), Tensor::from_vector(ids, {cfg.batch}), false);
    const auto [l, gn] = nn::backward_clip_step(cl.loss, params, opt);
    nn::clamp_logit_scale_(m.logit_scale());
    log.write({{"step", ts.step + 1}, {"loss", l}, {"lr", opt.lr()}, {"grad_norm", gn}, {"gamma", m.gamma()}});
    bar.update(ts.step + 1, {{"loss", l}, {"gamma", m.gamma()}});
    if (++ts.step % cfg.save_every == 0 || ts.step == end) ts.save(paths.state);
  }
  bar.finish();
  m.eval();
  nn::write_loss_plot_if_logged(paths.log, paths.svg, "posture-planning encoders: InfoNCE (train split key poses)",
                                {"loss"}, /*log_y=*/false);
  EncodersTrainResult r;
  r.steps = ts.step;
  r.final_loss = bar.smoothed("loss");
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

RetrievalResult pose_text_retrieval(const PoseTextEncoders& m, const text::Tokenizer& tok, const PostureScriptSet& set,
                                    const PoseStats& stats, int64_t group) {
  RetrievalResult r;
  r.group = group;
  if (group < 2) throw Error("encoders train: retrieval group must be >= 2, got " + std::to_string(group));
  ag::NoGradGuard ng;
  int64_t hit_p = 0, hit_s = 0;
  for (int64_t g0 = 0; g0 + group <= set.size(); g0 += group) {
    std::vector<int64_t> idx;
    std::vector<std::string> texts;
    for (int64_t i = g0; i < g0 + group; ++i) idx.push_back(i), texts.push_back(set.scripts[i]);
    const auto eb = text::encode_captions(tok, texts, m.config().max_tokens);
    const Tensor pe = m.embed_poses(ag::Variable(batch_poses(set, idx, stats))).data();
    const Tensor te = m.embed_scripts(eb.ids, eb.mask).data();
    const Tensor sim = matmul_t(pe, false, te, true);  // (G, G) rows poses, columns scripts
    const auto best_s = argmax(sim, 1).to_vector<int64_t>();
    const auto best_p = argmax(sim, 0).to_vector<int64_t>();
    for (int64_t i = 0; i < group; ++i) {
      hit_p += texts[best_s[i]] == texts[i];
      hit_s += texts[best_p[i]] == texts[i];  // the best pose for script i carries the same script
    }
    ++r.groups;
  }
  if (r.groups > 0) {
    r.pose_to_script_top1 = (double)hit_p / (r.groups * group);
    r.script_to_pose_top1 = (double)hit_s / (r.groups * group);
  }
  return r;
}

}  // namespace t2m::promotion
