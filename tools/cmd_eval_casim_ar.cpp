// cmd_eval_casim_ar.cpp — `t2m eval casim-ar --cond cls|tok --out DIR`: the text-to-motion table row of the
// autoregressive CASIM baseline on a data split with the `t2m eval motions` protocol (docs/CASIM.md).
//   t2m eval casim-ar --cond tok --out DIR [--split test] [--checkpoints D] [--compose N] [--length gt|end] [--max-frames 128]
//                     [--mm-prompts 32] [--samples 10] [--seed 0] [--runs 20] [--threads T]
// For every clip of the split (sorted by name) the real-motion row's caption (make_caption(labels, seed 7, index 0))
// is generated with casim::ArGenerator (batches of 32 prompts): --length gt (default) at the clip's length capped at
// --max-frames (round(frames / 4) tokens; the protocol of `t2m eval casim` for the diffusion rows), --length end: the
// GPT's end token decides. The first --mm-prompts captions get --samples samples (MultiModality). --compose N:
// instead the N two-clause clips "A, then B" of models/data/compose_samples.h made from the split's clips (seed
// 7), generated from their composed captions at their length (capped at 48 tokens) and scored against the
// composed real clips (FID reference). --reconstruct: instead of generating, the real clips (their centred
// --max-frames crop, trimmed to a multiple of 4 frames) through the tokenizer (encode, nearest codes, decode): the
// ceiling of the AR rows.
// DIR gets motions.json + .npy (models/eval/motion_dir_write.h) and eval.json.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "models/casim/ar_generate.h"
#include "models/casim/vq_train.h"
#include "models/data/captions.h"
#include "models/data/compose_samples.h"
#include "models/eval/evaluate_motions.h"
#include "models/eval/evaluator.h"
#include "models/eval/motion_dir_write.h"
#include "nn/checkpoint.h"
#include "nn/progress.h"
#include "tensor/parallel.h"
#include "tools/command.h"
#include "tools/score_motion_dir.h"
#include "tools/text_data.h"

namespace {

namespace fs = std::filesystem;
namespace cs = t2m::casim;
using json = nlohmann::json;
using t2m::Error;

constexpr uint64_t kRealCaptionSeed = 7;  // the real-motion row's captions (tools/cmd_eval_motions.cpp)

struct Args {
  t2m::cli::TextDataOptions data;
  std::string out, cond = "tok", split = "test", checkpoints = "models/checkpoints", length = "gt";
  std::string evaluator = "models/checkpoints/evaluator.t2mckpt";
  int compose = 0;
  bool reconstruct = false;
  int64_t mm_prompts = 32, samples = 10, max_frames = 128;
  uint64_t seed = 0;
  t2m::eval::EvalProtocol protocol;
};

void run(Args a) {
  const cs::ArCond cond = cs::ar_cond_from_name(a.cond);
  if (a.length != "gt" && a.length != "end") throw Error("eval casim-ar: --length must be gt or end, got " + a.length);
  if (a.compose < 0 || a.mm_prompts < 0 || a.samples < 2 || a.protocol.runs < 1 || a.max_frames < 4)
    throw Error("eval casim-ar: --compose, --mm-prompts >= 0, --samples >= 2, --runs >= 1, --max-frames >= 4");
  if (a.data.threads > 0) t2m::set_num_threads(a.data.threads);
  if (!fs::exists(a.evaluator)) throw Error("eval casim-ar: evaluator checkpoint '" + a.evaluator + "' not found");
  const auto split = t2m::data::split_from_name(a.split);
  auto td = t2m::cli::load_text_data(a.data);
  std::vector<t2m::data::MotionClip> clips = t2m::cli::split_clips(td, split, a.data.threads);
  if (clips.empty()) throw Error("eval casim-ar: the " + a.split + " split has no clips");
  std::sort(clips.begin(), clips.end(), [](const auto& x, const auto& y) { return x.name < y.name; });
  std::vector<std::string> captions;
  std::vector<int64_t> frames;
  if (a.compose > 0) {
    clips = t2m::data::make_composed_clips(clips, a.compose, kRealCaptionSeed);
    for (const auto& c : clips) captions.push_back(c.caption), frames.push_back(c.frames);
  } else {
    for (const auto& c : clips) {
      captions.push_back(t2m::data::make_caption(c.content, c.style, kRealCaptionSeed, 0).text);
      frames.push_back(c.frames);
    }
  }
  if (a.reconstruct) {  // the tokenizer's ceiling: real clips through VQ encode -> nearest codes -> decode
    const cs::VqBundle vq = cs::load_vq(a.checkpoints + "/casim_vq.t2mckpt");
    const int64_t f = vq.model->config().downsample();
    std::vector<t2m::eval::MotionEntry> rec;
    for (size_t i = 0; i < clips.size(); ++i) {
      const int64_t T = (std::min<int64_t>(clips[i].frames, a.max_frames) / f) * f, s0 = (clips[i].frames - T) / 2;
      if (T < f) continue;
      std::vector<float> x(clips[i].features.begin() + s0 * 257, clips[i].features.begin() + (s0 + T) * 257);
      t2m::data::normalize_features(x, vq.stats);
      const t2m::Tensor ids = vq.model->tokenize(t2m::Tensor::from_vector(x, {1, T, 257}));
      t2m::eval::MotionEntry e;
      char fn[32];
      std::snprintf(fn, sizeof fn, "%04zu.npy", i);
      e.file = fn, e.caption = captions[i];
      e.features = vq.model->detokenize(ids).to_vector<float>();
      t2m::data::denormalize_features(e.features, vq.stats);
      e.frames = T;
      rec.push_back(std::move(e));
    }
    t2m::eval::write_motion_dir(a.out, rec, {{"provenance", {{"what", "VQ reconstructions (casim_vq.t2mckpt) of the "
                                              "real " + a.split + " clips"}}}});
  }
  const cs::ArGenerator gen(a.checkpoints, cond);
  const auto t0 = std::chrono::steady_clock::now();
  json stats, provenance;
  std::string what = "VQ reconstructions (" + a.checkpoints + "/casim_vq.t2mckpt) of the real " +
                     std::string(a.compose > 0 ? "composed " : "") + "clips of the " + a.split + " split";
  if (!a.reconstruct) {
  const double c0 = cs::process_cpu_seconds();
  // Jobs: (caption index, sample); sample 0 of every caption is the main entry.
  struct Job {
    int64_t cap, sample;
  };
  std::vector<Job> jobs;
  const int64_t mm = std::min<int64_t>(a.mm_prompts, (int64_t)captions.size());
  for (int64_t i = 0; i < (int64_t)captions.size(); ++i)
    for (int64_t s = 0; s < (i < mm ? a.samples : 1); ++s) jobs.push_back({i, s});
  std::vector<t2m::eval::MotionEntry> entries(jobs.size());
  t2m::nn::Progress bar((int64_t)jobs.size(), "eval casim-ar-" + a.cond + ": generate");
  // Batches of 32 jobs with the same token count (gt) or any (end); every batch has its own seeded Generator.
  std::vector<size_t> order(jobs.size());
  for (size_t j = 0; j < jobs.size(); ++j) order[j] = j;
  auto tokens_of = [&](const Job& j) {
    return a.length == "gt" ? gen.tokens_for_seconds((double)std::min(frames[j.cap], a.max_frames) / 30.0) : int64_t{0};
  };
  std::stable_sort(order.begin(), order.end(), [&](size_t x, size_t y) { return tokens_of(jobs[x]) < tokens_of(jobs[y]); });
  size_t done = 0;
  for (size_t s = 0, batch_id = 0; s < order.size(); ++batch_id) {
    size_t e = s;
    while (e < order.size() && e - s < 32 && tokens_of(jobs[order[e]]) == tokens_of(jobs[order[s]])) ++e;
    std::vector<std::string> caps;
    for (size_t k = s; k < e; ++k) caps.push_back(captions[jobs[order[k]].cap]);
    cs::ArSampleOptions o;
    o.tokens = tokens_of(jobs[order[s]]);
    t2m::Generator rng(a.seed * 1000003 + batch_id);
    const auto motions = gen.generate(caps, o, rng);
    for (size_t k = s; k < e; ++k) {
      const Job& j = jobs[order[k]];
      auto& en = entries[order[k]];
      char f[40];
      std::snprintf(f, sizeof f, "%04lld_%02lld.npy", (long long)j.cap, (long long)j.sample);
      en.file = f;
      en.caption = captions[j.cap];
      en.prompt = j.cap < mm ? j.cap : -1;
      en.features = motions[k - s];
      en.frames = (int64_t)en.features.size() / 257;
    }
    done += e - s;
    bar.update((int64_t)done);
    s = e;
  }
  bar.finish();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu = cs::process_cpu_seconds() - c0;
  what = std::string("CASIM AR baseline casim-ar-") + a.cond + " (" + gen.gpt_path() + ", " +
                           (a.length == "gt" ? "clip lengths" : "end-token lengths") + ") for the " +
                           (a.compose > 0 ? std::to_string(clips.size()) + " composed two-clause clips of the " : "") +
                           "captions of the " + a.split + " split";
  stats = {{"generations", jobs.size()}, {"wall_s", wall}, {"cpu_s", cpu}, {"seed", a.seed},
                      {"mm_prompts", mm}, {"samples", a.samples}, {"length", a.length}, {"temperature", 1.0}};
  provenance = {{"what", what}, {"data", "Bandai-Namco-Research-Motiondataset 1+2 (CC BY-NC 4.0), " + a.split +
                            " split, captions from its labels (seed 7, index 0)" +
                            (a.compose > 0 ? ", composed 'A, then B' (compose_samples.h, seed 7)" : "")},
                           {"stats", stats}};
  t2m::eval::write_motion_dir(a.out, entries, {{"provenance", provenance}});
  }
  if (a.reconstruct)
    provenance = {{"what", what}, {"data", "Bandai-Namco-Research-Motiondataset 1+2 (CC BY-NC 4.0), " + a.split +
                                  " split, captions from its labels (seed 7, index 0)"}};

  t2m::cli::ScoreRequest sr;
  sr.dir = a.out, sr.evaluator = a.evaluator, sr.what = what, sr.reference = &clips, sr.protocol = a.protocol;
  sr.fid_reference = std::string("real ") + (a.compose > 0 ? "composed " : "") + "motions of the " + a.split +
                     " split (" + std::to_string(clips.size()) + " clips)";
  const std::string label = a.reconstruct ? std::string("casim-vq reconstruction") : "casim-ar-" + a.cond;
  sr.label = label + (a.compose > 0 ? std::string(" (compose)") : std::string());
  sr.summary = stats.dump();
  sr.fields = {{"data", provenance["data"]}, {"stats", stats}};
  t2m::cli::score_motion_dir(sr);
}

void add_eval_casim_ar(CLI::App& app) {
  auto* g = t2m::cli::command_group(app, "eval", "evaluate models and motions");
  auto a = std::make_shared<Args>();
  auto* c = g->add_subcommand("casim-ar", "generate the split's captions with the AR CASIM baseline and score them");
  c->add_option("--out", a->out, "motions directory to write (replaced if it exists); eval.json goes inside")
      ->required();
  c->add_option("--cond", a->cond, "conditioning: cls (sentence) or tok (CASIM token-level)")->capture_default_str();
  c->add_option("--split", a->split, "data split")->capture_default_str();
  c->add_option("--checkpoints", a->checkpoints, "directory with text_encoder, casim_vq, casim_ar_<cond>")
      ->capture_default_str();
  c->add_option("--evaluator", a->evaluator, "metric evaluator checkpoint")->capture_default_str();
  c->add_option("--length", a->length, "gt: the clips' lengths; end: the GPT's end token")->capture_default_str();
  c->add_option("--max-frames", a->max_frames, "cap of the clip lengths with --length gt (the evaluator scores "
                 "centred 128-frame crops; as `t2m eval casim`)")->capture_default_str();
  c->add_flag("--reconstruct", a->reconstruct, "score the tokenizer's reconstructions of the real clips instead "
              "(the AR baseline's ceiling)");
  c->add_option("--compose", a->compose, "score N composed two-clause clips of the split instead (0 = off)")
      ->capture_default_str();
  c->add_option("--mm-prompts", a->mm_prompts, "prompts with extra samples (MultiModality)")->capture_default_str();
  c->add_option("--samples", a->samples, "samples per MultiModality prompt")->capture_default_str();
  c->add_option("--seed", a->seed, "seed of the generations")->capture_default_str();
  c->add_option("--runs", a->protocol.runs, "seeded repetitions of the protocol (mean and 95% CI)")
      ->capture_default_str();
  c->add_option("--data", a->data.data_dir, "motion data directory");
  c->add_option("--cache", a->data.cache_dir, "cache directory");
  c->add_option("--threads", a->data.threads, "threads (0 = default)");
  c->callback([a] { run(*a); });
}

}  // namespace

T2M_COMMAND(add_eval_casim_ar);
