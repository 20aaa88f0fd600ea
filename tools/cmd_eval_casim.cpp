// cmd_eval_casim.cpp — `t2m eval casim --variant diff-cls|diff-mhsa|diff-mhca --out DIR`: the text-to-motion table
// rows of the diffusion CASIM baseline on a data split with the `t2m eval motions` protocol (docs/CASIM.md).
//   t2m eval casim --variant V --out DIR [--split test] [--checkpoints D] [--compose N] [--mm-prompts 32]
//                  [--samples 10] [--steps K] [--cfg W] [--max-frames 128] [--seed 0] [--runs 20] [--threads T]
//   t2m eval casim --model NAME --out DIR ...   any `t2m generate --model` kinematic model, one prompt per call
// Prompts: for every clip of the split (sorted by name) the real-motion row's caption (make_caption(labels, seed 7,
// index 0)), generated at the clip's length capped at --max-frames (the evaluator scores centred 128-frame crops);
// the first --mm-prompts captions get --samples samples (MultiModality). --compose N: instead the N two-clause
// clips "A, then B" of models/data/compose_samples.h made from the split's clips (seed 7), from their composed
// captions, scored against the composed real clips (FID reference). Batches of 32 prompts sorted by length; batch
// k draws its noise from seed + 7919 k (diffusion_generate.h). DIR gets motions.json + .npy and eval.json.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <memory>
#include <string>

#include "models/casim/diffusion_generate.h"
#include "models/data/captions.h"
#include "models/data/compose_samples.h"
#include "models/eval/evaluate_motions.h"
#include "models/eval/evaluator.h"
#include "models/eval/motion_dir_write.h"
#include "models/text/text_motion_model.h"
#include "nn/checkpoint.h"
#include "nn/progress.h"
#include "tensor/parallel.h"
#include "tools/command.h"
#include "tools/score_motion_dir.h"
#include "tools/kinematic_models.h"
#include "tools/text_data.h"

namespace {

namespace fs = std::filesystem;
namespace cs = t2m::casim;
using json = nlohmann::json;
using t2m::Error;

constexpr uint64_t kRealCaptionSeed = 7;  // the real-motion row's captions (tools/cmd_eval_motions.cpp)

struct Args {
  t2m::cli::TextDataOptions data;
  std::string out, variant, model, split = "test", checkpoints = "models/checkpoints";
  std::string evaluator = "models/checkpoints/evaluator.t2mckpt";
  int compose = 0;
  int64_t mm_prompts = 32, samples = 10, steps = 0, max_frames = 128, batch = 32;
  double cfg = -1;
  uint64_t seed = 0;
  t2m::eval::EvalProtocol protocol;
};

struct Job {
  int64_t cap, sample, frames;
};

void run(const Args& a) {
  if (a.variant.empty() == a.model.empty()) throw Error("eval casim: give exactly one of --variant and --model");
  if (!a.variant.empty() && a.variant != "diff-cls" && a.variant != "diff-mhsa" && a.variant != "diff-mhca")
    throw Error("eval casim: --variant must be diff-cls, diff-mhsa or diff-mhca, got '" + a.variant + "'");
  if (a.compose < 0 || a.mm_prompts < 0 || a.samples < 2 || a.protocol.runs < 1 || a.max_frames < 1 || a.batch < 1)
    throw Error("eval casim: --compose, --mm-prompts >= 0, --samples >= 2, --runs, --max-frames, --batch >= 1");
  if (a.data.threads > 0) t2m::set_num_threads(a.data.threads);
  if (!fs::exists(a.evaluator)) throw Error("eval casim: evaluator checkpoint '" + a.evaluator + "' not found");
  const auto split = t2m::data::split_from_name(a.split);
  auto td = t2m::cli::load_text_data(a.data);
  std::vector<t2m::data::MotionClip> clips = t2m::cli::split_clips(td, split, a.data.threads);
  if (clips.empty()) throw Error("eval casim: the " + a.split + " split has no clips");
  std::sort(clips.begin(), clips.end(), [](const auto& x, const auto& y) { return x.name < y.name; });
  std::vector<std::string> captions;
  std::vector<int64_t> frames;
  if (a.compose > 0) clips = t2m::data::make_composed_clips(clips, a.compose, kRealCaptionSeed);
  for (const auto& c : clips) {
    captions.push_back(a.compose > 0 ? c.caption : t2m::data::make_caption(c.content, c.style, kRealCaptionSeed, 0).text);
    frames.push_back(std::min<int64_t>(c.frames, a.max_frames));
  }
  const std::string name = a.model.empty() ? "casim-" + a.variant : a.model;

  std::vector<Job> jobs;
  const int64_t mm = std::min<int64_t>(a.mm_prompts, (int64_t)captions.size());
  for (int64_t i = 0; i < (int64_t)captions.size(); ++i)
    for (int64_t s = 0; s < (i < mm ? a.samples : 1); ++s) jobs.push_back({i, s, frames[(size_t)i]});
  std::vector<size_t> order(jobs.size());
  for (size_t j = 0; j < jobs.size(); ++j) order[j] = j;
  std::stable_sort(order.begin(), order.end(), [&](size_t x, size_t y) { return jobs[x].frames < jobs[y].frames; });
  std::vector<t2m::eval::MotionEntry> entries(jobs.size());
  const auto t0 = std::chrono::steady_clock::now();
  const std::clock_t c0 = std::clock();
  json sampler;
  t2m::nn::Progress bar((int64_t)jobs.size(), "eval " + name + ": generate");
  auto store = [&](size_t k, std::vector<float> f) {
    const Job& j = jobs[order[k]];
    auto& en = entries[order[k]];
    char fn[40];
    std::snprintf(fn, sizeof fn, "%04lld_%02lld.npy", (long long)j.cap, (long long)j.sample);
    en.file = fn;
    en.caption = captions[(size_t)j.cap];
    en.prompt = j.cap < mm ? j.cap : -1;
    en.features = std::move(f);
    en.frames = (int64_t)en.features.size() / 257;
  };
  if (!a.variant.empty()) {
    const std::string v = a.variant.substr(5);
    const cs::DiffusionBundle b = cs::load_diffusion_checkpoint(a.checkpoints + "/casim_diff_" + v + ".t2mckpt");
    const auto tb = t2m::text::load_text_motion_model(a.checkpoints + "/text_encoder.t2mckpt");
    cs::SamplerOptions o = b.sampler;
    if (a.steps > 0) o.steps = a.steps;
    if (a.cfg >= 0) o.guidance = a.cfg;
    sampler = {{"kind", o.eta == 0 ? "DDIM" : "DDPM"}, {"steps", o.steps}, {"guidance", o.guidance},
               {"train_window_frames", b.window}, {"checkpoint_steps", b.train.value("steps", int64_t(0))}};
    for (size_t s = 0, k = 0; s < order.size(); s += (size_t)a.batch, ++k) {
      const size_t e = std::min(order.size(), s + (size_t)a.batch);
      std::vector<std::string> caps;
      std::vector<int64_t> fr;
      for (size_t i = s; i < e; ++i) caps.push_back(captions[(size_t)jobs[order[i]].cap]), fr.push_back(jobs[order[i]].frames);
      auto out = cs::generate_motion_features(b, tb, caps, fr, o, a.seed + 104729 * k, a.batch);
      for (size_t i = s; i < e; ++i) store(i, std::move(out[i - s]));
      bar.update((int64_t)e);
    }
  } else {
    const auto& km = t2m::cli::find_kinematic_model(a.model);
    for (size_t i = 0; i < order.size(); ++i) {
      t2m::cli::KinematicRequest r;
      r.prompt = captions[(size_t)jobs[order[i]].cap];
      r.checkpoints = a.checkpoints;
      r.seed = a.seed + i;
      r.length_s = jobs[order[i]].frames / 30.0;
      r.cfg = a.cfg;
      r.steps = (int)a.steps;
      auto res = km.generate(r);
      if (i == 0) sampler = res.info;
      store(i, std::move(res.features));
      bar.update((int64_t)i + 1);
    }
  }
  bar.finish();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu = double(std::clock() - c0) / CLOCKS_PER_SEC;
  const std::string what = (a.model.empty() ? "CASIM baseline " : "kinematic model ") + name + " for the " +
                           (a.compose > 0 ? std::to_string(clips.size()) + " composed two-clause clips of the " : "") +
                           "captions of the " + a.split + " split (clip lengths capped at " +
                           std::to_string(a.max_frames) + " frames)";
  const json stats = {{"generations", jobs.size()}, {"wall_s", wall}, {"cpu_s", cpu}, {"seed", a.seed},
                      {"mm_prompts", mm}, {"samples", a.samples}, {"sampler", sampler}};
  const json provenance = {{"what", what},
                           {"data", "Bandai-Namco-Research-Motiondataset 1+2 (CC BY-NC 4.0), " + a.split +
                                        " split, captions from its labels (seed 7, index 0)" +
                                        (a.compose > 0 ? ", composed 'A, then B' (compose_samples.h, seed 7)" : "")},
                           {"stats", stats}};
  t2m::eval::write_motion_dir(a.out, entries, {{"provenance", provenance}});

  t2m::cli::ScoreRequest sr;
  sr.dir = a.out, sr.evaluator = a.evaluator, sr.what = what, sr.reference = &clips, sr.protocol = a.protocol;
  sr.fid_reference = std::string("real ") + (a.compose > 0 ? "composed " : "") + "motions of the " + a.split +
                     " split (" + std::to_string(clips.size()) + " clips)";
  sr.label = name + (a.compose > 0 ? std::string(" (compose)") : std::string());
  char summary[96];
  std::snprintf(summary, sizeof summary, "generated in %.1f s wall, %.1f s CPU", wall, cpu);
  sr.summary = summary;
  sr.fields = {{"data", provenance["data"]}, {"stats", stats}};
  t2m::cli::score_motion_dir(sr);
}

void add_eval_casim(CLI::App& app) {
  auto* g = t2m::cli::command_group(app, "eval", "evaluate models and motions");
  auto a = std::make_shared<Args>();
  auto* c = g->add_subcommand("casim", "generate the split's captions with a CASIM diffusion baseline and score them");
  c->add_option("--out", a->out, "motions directory to write (replaced if it exists); eval.json goes inside")
      ->required();
  c->add_option("--variant", a->variant, "diff-cls | diff-mhsa | diff-mhca (batched)");
  c->add_option("--model", a->model, "or any `t2m generate --model` kinematic model (one prompt per call)");
  c->add_option("--split", a->split, "data split")->capture_default_str();
  c->add_option("--checkpoints", a->checkpoints, "directory with text_encoder and casim_diff_<v>")->capture_default_str();
  c->add_option("--evaluator", a->evaluator, "metric evaluator checkpoint")->capture_default_str();
  c->add_option("--compose", a->compose, "score N composed two-clause clips of the split instead (0 = off)")
      ->capture_default_str();
  c->add_option("--mm-prompts", a->mm_prompts, "prompts with extra samples (MultiModality)")->capture_default_str();
  c->add_option("--samples", a->samples, "samples per MultiModality prompt")->capture_default_str();
  c->add_option("--steps", a->steps, "sampling steps (0 = the checkpoint's)")->capture_default_str();
  c->add_option("--cfg", a->cfg, "guidance weight (< 0 = the checkpoint's)")->capture_default_str();
  c->add_option("--max-frames", a->max_frames, "cap of the generated lengths (frames)")->capture_default_str();
  c->add_option("--batch", a->batch, "prompts per sampling batch")->capture_default_str();
  c->add_option("--seed", a->seed, "seed of the generations")->capture_default_str();
  c->add_option("--runs", a->protocol.runs, "seeded repetitions of the protocol (mean and 95% CI)")
      ->capture_default_str();
  c->add_option("--data", a->data.data_dir, "motion data directory");
  c->add_option("--cache", a->data.cache_dir, "cache directory");
  c->add_option("--threads", a->data.threads, "threads (0 = default)");
  c->callback([a] { run(*a); });
}

}  // namespace

T2M_COMMAND(add_eval_casim);
