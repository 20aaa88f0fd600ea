// cmd_eval_text2bfm.cpp — `t2m eval text2bfm`: the text-to-motion table row of a Text2BFM chain (or of the BFM's
// tracking rollouts, the controller's reference row) on a data split with the `t2m eval motions` protocol.
//   t2m eval text2bfm --out DIR [--split test] [--checkpoints D] [--gen CKPT] [--vbb CKPT] [--text CKPT]
//                     [--bfm CKPT] [--cfg 1.5] [--steps N] [--mm-prompts 32] [--samples 10] [--seed 0]
//                     [--max-clips N] [--runs 20] [--threads T] [--candidates K] [--clip-start]
//                     [--tracking [--through-vbb] [--standing-start]]
// For every clip of the split (sorted by name; --max-clips N: N spread evenly) the caption the real-motion row uses
// (make_caption(labels, seed 7, index 0)) is generated at the clip's length with the chain (no render), the
// simulated states s_1..s_T become raw features (models/text2bfm/eval_generation.h), DIR gets a motions directory
// (motions.json + .npy, docs/TEXT.md) with --samples samples of --mm-prompts prompts for MultiModality, and the
// evaluator scores it (models/eval/evaluate_motions.h, FID against the split's real clips) into DIR/eval.json.
// --tracking: instead of generating, the BFM tracks each real clip from its reference start with its Eq 2 latents
// (models/bfm/track_eval.h); the rollouts are scored the same way (no MultiModality). --through-vbb: those latents
// first go through the VBB (reconstruct_clip_latents: encoder mean, decoder, Proj), the bottleneck's share;
// --standing-start: the tracking starts at qpos0 at rest, as generations do. --clip-start (generations): each starts
// in its clip's first state instead (a diagnostic). --candidates K: as `t2m generate --candidates`. eval.json's
// stats.fell_by_content counts each clip's main rollout by content label.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <set>
#include <string>

#include "models/bfm/policy_checkpoint.h"
#include "models/bfm/ref_motions.h"
#include "models/bfm/track_eval.h"
#include "models/data/captions.h"
#include "models/eval/evaluate_motions.h"
#include "models/eval/evaluator.h"
#include "models/eval/motion_dir_write.h"
#include "models/text2bfm/eval_generation.h"
#include "models/text2bfm/pipeline_checkpoints.h"
#include "models/text2bfm/vbb_checkpoint.h"
#include "models/text2bfm/vbb_eval.h"
#include "nn/checkpoint.h"
#include "nn/progress.h"
#include "tensor/parallel.h"
#include "tools/command.h"
#include "tools/score_motion_dir.h"
#include "tools/text_data.h"

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using t2m::Error;
namespace t2b = t2m::text2bfm;

constexpr uint64_t kRealCaptionSeed = 7;  // the real-motion row's captions (tools/cmd_eval_motions.cpp)

struct Args {
  t2m::cli::TextDataOptions data;
  std::string out, split = "test", checkpoints = "models/checkpoints", gen, vbb, text, bfm;
  std::string evaluator = "models/checkpoints/evaluator.t2mckpt", label;
  t2b::EvalGenOptions opt = [] { t2b::EvalGenOptions o; o.gen.steps = 0; return o; }();
  int max_clips = 0;
  bool tracking = false, through_vbb = false, standing_start = false, clip_start = false;
  t2m::eval::EvalProtocol protocol;
};

// {content label: {"clips": n, "fell": f}} over the scored clips (their main rollout), and a one-line summary.
json fell_by_content(const std::vector<std::string>& content, const std::vector<bool>& fell) {
  std::map<std::string, std::pair<int, int>> by;
  for (size_t i = 0; i < content.size(); ++i) {
    auto& [n, f] = by[content[i]];
    ++n;
    f += fell[i] ? 1 : 0;
  }
  json j = json::object();
  std::string line = "fell by content:";
  for (const auto& [c, nf] : by) {
    j[c] = {{"clips", nf.first}, {"fell", nf.second}};
    line += " " + c + " " + std::to_string(nf.second) + "/" + std::to_string(nf.first);
  }
  std::printf("%s\n", line.c_str());
  return j;
}

// The reference motions (models/bfm/ref_motions.h) of the picked clips of the split, in their order (names sorted);
// only they are retargeted. Error when one of them has none.
t2m::bfm::RefMotions picked_ref_motions(const t2m::sim::Humanoid& h, const t2m::data::Manifest& manifest,
                                        t2m::data::Split split, const std::vector<std::string>& names) {
  const std::set<std::string> want(names.begin(), names.end());
  std::vector<const t2m::data::ClipInfo*> sel;
  for (const auto* c : t2m::bfm::select_split_clips(manifest, split, 0))
    if (want.count(c->name)) sel.push_back(c);
  auto refs = t2m::bfm::load_ref_motions(h, sel);
  if (refs.names != names) {
    const std::set<std::string> have(refs.names.begin(), refs.names.end());
    for (const auto& n : names)
      if (!have.count(n)) throw Error("eval text2bfm: no reference motion for clip " + n);
    throw Error("eval text2bfm: the reference motions are not in the clips' order");
  }
  return refs;
}

void run(Args a) {
  if (a.data.threads < 0) throw Error("eval text2bfm: --threads must be >= 0");
  if (a.protocol.runs < 1) throw Error("eval text2bfm: --runs must be >= 1");
  if (a.max_clips < 0) throw Error("eval text2bfm: --max-clips must be >= 0");
  const int threads = a.data.threads > 0 ? a.data.threads : t2m::get_num_threads();
  if (!fs::exists(a.evaluator))
    throw Error("eval text2bfm: evaluator checkpoint '" + a.evaluator + "' not found (t2m train evaluator)");
  const auto split = t2m::data::split_from_name(a.split);
  auto td = t2m::cli::load_text_data(a.data);
  std::vector<t2m::data::MotionClip> clips = t2m::cli::split_clips(td, split, threads);
  if (clips.empty()) throw Error("eval text2bfm: the " + a.split + " split has no clips");
  std::sort(clips.begin(), clips.end(), [](const auto& x, const auto& y) { return x.name < y.name; });
  std::vector<int> pick;
  const int n_all = (int)clips.size();
  const int n = a.max_clips > 0 && a.max_clips < n_all ? a.max_clips : n_all;
  for (int k = 0; k < n; ++k) pick.push_back(int((int64_t)k * n_all / n));
  std::vector<std::string> picked_names;  // sorted, as clips
  for (int i : pick) picked_names.push_back(clips[i].name);

  std::vector<t2m::eval::MotionEntry> entries;
  json stats;
  std::string what;
  auto paths = t2b::PipelinePaths::in_dir(a.checkpoints);  // the set, with the files given on the command line
  if (!a.gen.empty()) paths.gen = a.gen;
  if (!a.vbb.empty()) paths.vbb = a.vbb;
  if (!a.text.empty()) paths.text = a.text;
  if (!a.bfm.empty()) paths.bfm = a.bfm;
  const auto tp0 = std::chrono::steady_clock::now();
  if (a.tracking) {
    // The controller's share: the BFM tracking the real clips with their Eq 2 latents, from the reference start (or
    // standing, --standing-start).
    const std::string& bfm_p = paths.bfm;
    if (!fs::exists(bfm_p)) throw Error("eval text2bfm: missing BFM " + bfm_p + " (t2m train bfm)");
    auto agent = t2m::bfm::load_policy(bfm_p);
    auto h = t2m::sim::Humanoid::create();
    t2m::set_num_threads(threads);
    const auto sel = picked_ref_motions(*h, td.manifest, split, picked_names);  // clip c: clips[pick[c]]
    std::unique_ptr<t2b::Vbb> vbb;
    const std::string& vbb_p = paths.vbb;
    if (a.through_vbb) {
      vbb = t2b::load_vbb(vbb_p);
      if (vbb->config().in_dim != agent->config().z_dim)
        throw Error("eval text2bfm: the VBB " + vbb_p + " does not take this BFM's latents (in_dim " +
                    std::to_string(vbb->config().in_dim) + ", z_dim " + std::to_string(agent->config().z_dim) + ")");
    }
    t2m::bfm::TrackLatentMap through;
    if (vbb) through = [&](const t2m::Tensor& z) { return t2b::reconstruct_clip_latents(*vbb, z); };
    const auto start = a.standing_start ? t2m::bfm::TrackStart::standing : t2m::bfm::TrackStart::reference;
    const auto res = t2m::bfm::track_bfm(*agent, h, sel, {}, 0, through, start);
    std::vector<std::string> content;
    std::vector<bool> clip_fell;
    for (int c = 0; c < sel.clips(); ++c) {
      const auto* clip = &clips[pick[c]];
      content.push_back(clip->content);
      clip_fell.push_back(res[c].fell);
      t2m::eval::MotionEntry e;
      e.caption = t2m::data::make_caption(clip->content, clip->style, kRealCaptionSeed, 0).text;
      char f[32];
      std::snprintf(f, sizeof f, "%04d.npy", c);
      e.file = f;
      e.features = t2b::trajectory_features(*h, res[c].simulated, 0);
      e.frames = (int64_t)e.features.size() / 257;
      entries.push_back(std::move(e));
    }
    stats = {{"clips", sel.clips()}, {"fell", std::count(clip_fell.begin(), clip_fell.end(), true)}, {"bfm", bfm_p},
             {"fell_by_content", fell_by_content(content, clip_fell)}};
    what = std::string("BFM tracking rollouts (Eq 2 latents of the real clips, ") +
           (a.standing_start ? "standing start" : "reference start") + ") of the " + a.split + " split, " + bfm_p;
    if (a.standing_start) stats["start"] = "standing";
    if (vbb) {
      stats["through_vbb"] = vbb_p;
      what += ", latents through the VBB " + vbb_p;
    }
  } else {
    auto models = t2b::load_text2bfm(paths);
    if (a.opt.gen.steps == 0) a.opt.gen.steps = models.gen.objective == "diffusion" ? 50 : 16;
    a.opt.gen.validate();  // bad --cfg / --steps / --candidates before any work
    for (const auto& w : models.warnings) std::fprintf(stderr, "eval text2bfm: warning: %s\n", w.c_str());
    std::vector<t2b::EvalItem> items;
    for (int i : pick)
      items.push_back({t2m::data::make_caption(clips[i].content, clips[i].style, kRealCaptionSeed, 0).text,
                       (int64_t)clips[i].frames});
    if (a.clip_start) {  // each generation starts in its clip's first state (a diagnostic: the clip is not known
                         // to a text prompt)
      const auto refs = picked_ref_motions(*models.humanoid, td.manifest, split, picked_names);
      for (size_t k = 0; k < items.size(); ++k) {
        const t2m::sim::QposTrajectory first = refs.trajectory((int)k, 0, 1);
        items[k].start_qpos = first.qpos, items[k].start_qvel = first.qvel;
      }
    }
    a.opt.mm_prompts = std::min<int64_t>(a.opt.mm_prompts, (int64_t)items.size());
    a.opt.jobs = threads;
    t2m::set_num_threads(1);  // one generation per thread
    const int64_t total = (int64_t)items.size() + a.opt.mm_prompts * (a.opt.samples - 1);
    t2m::nn::Progress bar(total, "eval text2bfm: generate");
    auto r = t2b::generate_eval_motions(models, items, a.opt, [&](int64_t done, int64_t) { bar.update(done); });
    bar.finish();
    t2m::set_num_threads(threads);
    entries = std::move(r.entries);
    const auto& s = r.stats;
    stats = {{"generations", s.generations}, {"control_steps", s.control_steps}, {"jobs", threads},
             {"wall_s", s.wall_s}, {"cpu_s", s.cpu_s}, {"stage_wall_s_summed",
             {{"text", s.text_s}, {"sample", s.sample_s}, {"decode", s.decode_s}, {"rollout", s.rollout_s}}},
             {"fell", s.fell}, {"mean_first_fall_s", s.mean_first_fall_s},
             {"checkpoints", {{"text", paths.text}, {"vbb", paths.vbb}, {"gen", paths.gen}, {"bfm", paths.bfm}}},
             {"objective", models.gen.objective}, {"cfg", a.opt.gen.cfg}, {"steps", a.opt.gen.steps}, {"seed", a.opt.seed},
             {"candidates", a.opt.gen.candidates}, {"mm_prompts", a.opt.mm_prompts}, {"samples", a.opt.samples},
             {"start", a.clip_start ? "the clip's first state" : "standing"}};
    std::vector<std::string> content;
    for (int i : pick) content.push_back(clips[i].content);
    stats["fell_by_content"] = fell_by_content(content, r.item_fell);  // each clip's main generation
    char cfg[32];
    std::snprintf(cfg, sizeof cfg, "%g", a.opt.gen.cfg);
    what = "Text2BFM generations (" + paths.gen + ", " + models.gen.objective + ", cfg " + cfg + ", " +
           std::to_string(a.opt.gen.steps) + " steps" +
           (a.opt.gen.candidates > 1 ? ", longest upright of " + std::to_string(a.opt.gen.candidates) + " candidates"
                                     : "") +
           (a.clip_start ? ", each from its clip's first state" : "") + ") for the captions of the " + a.split +
           " split";
    std::printf("generated %lld motions (%lld control steps) in %.1f s wall, %.1f s CPU, %d thread(s); %lld fell "
                "(mean first fall %.2f s)\n", (long long)s.generations, (long long)s.control_steps, s.wall_s,
                s.cpu_s, threads, (long long)s.fell, s.mean_first_fall_s);
  }
  const double produce_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - tp0).count();
  const json provenance = {{"what", what}, {"data", "Bandai-Namco-Research-Motiondataset 1+2 (CC BY-NC 4.0), " +
                            a.split + " split, captions from its labels (seed 7, index 0)"}, {"stats", stats}};
  t2m::eval::write_motion_dir(a.out, entries, {{"provenance", provenance}});

  // Score with the evaluator exactly as `t2m eval motions OUT` does (FID reference: the split's real clips).
  t2m::cli::ScoreRequest sr;
  sr.dir = a.out, sr.evaluator = a.evaluator, sr.what = what, sr.reference = &clips, sr.protocol = a.protocol;
  sr.fid_reference = "real motions of the " + a.split + " split (" + std::to_string(clips.size()) + " clips)";
  const char* track_label = a.through_vbb ? "BFM tracking (real Eq 2 latents through the VBB)"
                                          : "BFM tracking (real Eq 2 latents)";
  sr.label = a.label.empty() ? (a.tracking ? track_label : "Text2BFM") : a.label;
  sr.summary = "Bandai-Namco, our " + a.split + " split";
  sr.fields = {{"data", provenance["data"]}, {"stats", stats}, {"produce_s", produce_s}};
  t2m::cli::score_motion_dir(sr);
  std::printf("motions: %s/motions.json  report: %s/eval.json\n", a.out.c_str(), a.out.c_str());
}

void add_eval_text2bfm(CLI::App& app) {
  auto* g = t2m::cli::command_group(app, "eval", "evaluate models and motions");
  auto a = std::make_shared<Args>();
  auto* c = g->add_subcommand("text2bfm", "generate the split's captions with Text2BFM and score them (table row)");
  c->add_option("--out", a->out, "motions directory to write (replaced if it exists); eval.json goes inside")
      ->required();
  c->add_option("--split", a->split, "data split whose captions and lengths are generated")->capture_default_str();
  c->add_option("--checkpoints", a->checkpoints, "directory with the four .t2mckpt files")->capture_default_str();
  c->add_option("--gen", a->gen, "generator checkpoint (default CHECKPOINTS/gen_small.t2mckpt)");
  c->add_option("--vbb", a->vbb, "VBB checkpoint (default CHECKPOINTS/vbb_small.t2mckpt)");
  c->add_option("--text", a->text, "text encoder checkpoint (default CHECKPOINTS/text_encoder.t2mckpt)");
  c->add_option("--bfm", a->bfm, "BFM policy checkpoint (default CHECKPOINTS/bfm_stand.t2mckpt)");
  c->add_option("--evaluator", a->evaluator, "metric evaluator checkpoint")->capture_default_str();
  c->add_option("--cfg", a->opt.gen.cfg, "classifier-free guidance weight w")->capture_default_str();
  c->add_option("--steps", a->opt.gen.steps, "sampler steps (0: 16 Euler steps for a flow generator, 50 DDIM "
                 "steps for a diffusion one)")->capture_default_str();
  c->add_option("--seed", a->opt.seed, "seed of the generations (per clip and sample)")->capture_default_str();
  c->add_option("--candidates", a->opt.gen.candidates, "programs tried per generation; the rollout upright longest "
                "is kept (as `t2m generate --candidates`)")->capture_default_str();
  c->add_option("--mm-prompts", a->opt.mm_prompts, "prompts with extra samples (MultiModality)")
      ->capture_default_str();
  c->add_option("--samples", a->opt.samples, "samples per MultiModality prompt")->capture_default_str();
  c->add_option("--max-clips", a->max_clips, "use N clips spread over the split (0 = all)")->capture_default_str();
  c->add_option("--runs", a->protocol.runs, "seeded repetitions of the protocol (mean and 95% CI)")
      ->capture_default_str();
  c->add_option("--label", a->label, "row label of the printed table line");
  c->add_flag("--tracking", a->tracking, "score the BFM's tracking rollouts of the real clips instead");
  c->add_flag("--through-vbb", a->through_vbb,
              "with --tracking: the real clips' latents go through the VBB first (encoder mean, decoder, Proj)")
      ->needs("--tracking");
  c->add_flag("--standing-start", a->standing_start,
              "with --tracking: the body starts standing at rest (qpos0), as generations do, not in the clip's "
              "first state")
      ->needs("--tracking");
  c->add_flag("--clip-start", a->clip_start,
              "generations start in the first state of the clip their caption came from, not standing (a diagnostic)")
      ->excludes("--tracking");
  c->add_option("--data", a->data.data_dir, "motion data directory");
  c->add_option("--cache", a->data.cache_dir, "cache directory");
  c->add_option("--threads", a->data.threads, "threads: generations run in parallel over clips (0 = default)");
  c->callback([a] { run(*a); });
}

}  // namespace

T2M_COMMAND(add_eval_text2bfm);
