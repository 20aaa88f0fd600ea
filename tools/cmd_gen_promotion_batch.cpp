// cmd_gen_promotion_batch.cpp — `t2m eval promotion-gen --out DIR`: a `t2m eval motions` directory of PRO-Motion
// generations, one per caption of a data split (the real-motion row's captions: make_caption(labels, seed 7,
// index 0)), with the models loaded once (promotion_pipeline.h). Score it with `t2m eval motions DIR`.
//   t2m eval promotion-gen --out DIR [--checkpoints D] [--split test] [--clips 0] [--candidates 8] [--seed 0]
// --clips N > 0: every k-th clip by name so that N are taken (R-precision needs >= 32); 0 = every clip. Prompt i
// uses seed + i. DIR/motions.json carries the provenance (split, clips, wall time).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "models/data/captions.h"
#include "models/data/dataset.h"
#include "models/data/loader.h"
#include "models/data/splits.h"
#include "models/eval/motion_dir_write.h"
#include "models/promotion/promotion_pipeline.h"
#include "nn/progress.h"
#include "tensor/parallel.h"
#include "tools/command.h"

namespace {

using json = nlohmann::json;
using t2m::Error;
namespace pm = t2m::promotion;

struct Args {
  std::string out, checkpoints = "models/checkpoints", manifest, split = "test";
  int clips = 0, candidates = 8, threads = 0, posture_steps = pm::PromotionOptions().posture_steps;
  uint64_t seed = 0;
};

void run(const Args& a) {
  if (a.threads > 0) t2m::set_num_threads(a.threads);
  if (a.clips < 0 || a.candidates < 1) throw Error("eval promotion-gen: --clips >= 0 and --candidates >= 1");
  const pm::PromotionModels m = pm::load_promotion_models(a.checkpoints);
  const std::string mpath = a.manifest.empty() ? t2m::data::default_cache_dir() + "/bandai/manifest.json" : a.manifest;
  const auto manifest = t2m::data::load_manifest(mpath);
  std::vector<const t2m::data::ClipInfo*> clips;
  std::vector<std::string> names;
  for (const auto& c : manifest.clips) names.push_back(c.name);
  const auto splits = t2m::data::assign_splits(names);
  const auto which = t2m::data::split_from_name(a.split);
  for (const auto& c : manifest.clips)
    if (splits.at(c.name) == which) clips.push_back(&c);
  std::sort(clips.begin(), clips.end(), [](auto* x, auto* y) { return x->name < y->name; });
  if (clips.empty()) throw Error("eval promotion-gen: the " + a.split + " split has no clips");
  const size_t n = a.clips == 0 ? clips.size() : std::min<size_t>(a.clips, clips.size()), step = clips.size() / n;
  std::vector<t2m::eval::MotionEntry> entries;
  pm::PromotionOptions o;
  o.candidates = a.candidates;
  o.posture_steps = a.posture_steps;
  const auto t0 = std::chrono::steady_clock::now();
  t2m::nn::Progress bar((int64_t)n, "eval promotion-gen");
  json used = json::array();
  for (size_t i = 0; i < n; ++i) {
    const auto* c = clips[i * step];
    t2m::eval::MotionEntry e;
    e.caption = t2m::data::make_caption(c->content_label, c->style_label, 7, 0).text;
    o.seed = a.seed + i;
    e.features = pm::generate_promotion(m, e.caption, o).features;
    e.frames = (int64_t)e.features.size() / t2m::data::kFeatureDim;
    char fn[32];
    std::snprintf(fn, sizeof fn, "%04zu.npy", i);
    e.file = fn;
    entries.push_back(std::move(e));
    used.push_back(c->name);
    bar.update((int64_t)i + 1);
  }
  bar.finish();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const json prov = {{"what", "PRO-Motion baseline (rule planner, posture diffuser, Viterbi, go-diffuser), one "
                              "motion per caption, " + std::to_string(n) + " of " + std::to_string(clips.size()) +
                              " " + a.split + " clips"},
                     {"data", "Bandai-Namco-Research-Motiondataset 1+2 (CC BY-NC 4.0), " + a.split +
                                  " split, captions from its labels (seed 7, index 0)"},
                     {"clips", used}, {"wall_s", wall}, {"seed", a.seed}, {"candidates", a.candidates},
                     {"posture_steps", a.posture_steps}};
  t2m::eval::write_motion_dir(a.out, entries, {{"provenance", prov}});
  std::printf("eval promotion-gen: %zu motions in %.1f s -> %s (score: t2m eval motions %s)\n", n, wall,
              a.out.c_str(), a.out.c_str());
}

void add_eval_promotion_gen(CLI::App& app) {
  auto* grp = t2m::cli::command_group(app, "eval", "evaluate a model");
  auto a = std::make_shared<Args>();
  auto* c = grp->add_subcommand("promotion-gen", "write a motions directory of PRO-Motion generations for a split");
  c->add_option("--out", a->out, "motions directory to write")->required();
  c->add_option("--checkpoints", a->checkpoints, "directory with the promotion_* files")->capture_default_str();
  c->add_option("--manifest", a->manifest, "data manifest (default ~/.cache/t2m/bandai/manifest.json)");
  c->add_option("--split", a->split, "train, val or test")->capture_default_str();
  c->add_option("--clips", a->clips, "number of clips (0 = all)")->capture_default_str();
  c->add_option("--candidates", a->candidates, "posture candidates per script")->capture_default_str();
  c->add_option("--seed", a->seed, "seed of prompt 0")->capture_default_str();
  c->add_option("--posture-steps", a->posture_steps, "posture sampling steps (0 = all 1000, DDPM)")
      ->capture_default_str();
  c->add_option("--threads", a->threads, "threads (0 = default)");
  c->callback([a] { run(*a); });
}

}  // namespace

T2M_COMMAND(add_eval_promotion_gen);
