// cmd_train_bfm.cpp — `t2m train bfm`: the behavior foundation model (FB agent) in resumable chunks.
//   t2m train bfm [--out DIR] [--minutes M | --updates N] [--total-updates N] [--seed S] [--threads T]
//                 [--seed-transitions N] [--ref-clips N] [--offline-updates N] [--export POLICY.t2mckpt] ...
// DIR (default $T2M_CACHE/bfm/default, i.e. ~/.cache/t2m/bfm/default) holds config.json (the run's config, written
// by the first invocation and read by later ones; flags given again must agree with it), the seed buffer, the
// training state (resumed automatically), log.jsonl and loss.svg. Each invocation trains until --minutes or
// --updates or the total is reached, saving atomically every --save-minutes and at the end. See docs/BFM.md.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <utility>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "models/bfm/planner_demos.h"
#include "models/bfm/policy_checkpoint.h"
#include "models/bfm/ref_motions.h"
#include "models/bfm/track_eval.h"
#include "models/bfm/trainer.h"
#include "models/data/dataset.h"
#include "nn/checkpoint.h"
#include "nn/progress.h"
#include "nn/train_log.h"
#include "tensor/parallel.h"
#include "tools/command.h"

namespace {

using t2m::Error;
using json = nlohmann::json;
namespace fs = std::filesystem;
namespace bfm = t2m::bfm;

struct TrainBfmArgs {
  std::string out, manifest, export_path;
  double minutes = 0, save_minutes = 5;
  int64_t updates = 0;
  int threads = 0, log_every = 20;
  bool export_only = false;
  bfm::BfmTrainConfig cfg;
};

void export_policy(bfm::BfmTrainer& tr, const bfm::BfmTrainConfig& cfg, const std::string& path) {
  const json info = {{"updates", tr.step()},
                     {"run_config", cfg.to_json()},
                     {"data", "Bandai-Namco-Research-Motiondataset (CC BY-NC 4.0), train split"}};
  if (const fs::path p(path); p.has_parent_path()) fs::create_directories(p.parent_path());
  bfm::save_policy(tr.agent(), path, info);
  std::printf("wrote %s (actor + B + config, update %lld)\n", path.c_str(), (long long)tr.step());
}

void run_train_bfm(const TrainBfmArgs& a, CLI::App* app) {
  using clock = std::chrono::steady_clock;
  const auto t_start = clock::now();
  if (a.threads > 0) t2m::set_num_threads(a.threads);
  const std::string dir = a.out.empty() ? t2m::data::default_cache_dir() + "/bfm/default" : a.out;
  fs::create_directories(dir);
  // Config: config.json of the run when present; flags given on this command line override it (then TrainState
  // refuses to resume if they change what the state was trained with).
  bfm::BfmTrainConfig cfg = a.cfg;
  const std::string cfg_path = dir + "/config.json";
  if (fs::exists(cfg_path)) {
    json j;
    try {
      std::ifstream f(cfg_path);
      f >> j;
    } catch (const std::exception& e) {
      throw Error("train bfm: cannot parse " + cfg_path + ": " + e.what());
    }
    cfg = bfm::BfmTrainConfig::from_json(j);  // then the flags given on this command line
    bfm::BfmTrainConfig& f = cfg;
    const bfm::BfmTrainConfig& g = a.cfg;
    const std::pair<const char*, std::function<void()>> flags[] = {
        {"--seed", [&] { f.seed = g.seed; }},
        {"--ref-clips", [&] { f.ref_clips = g.ref_clips; }},
        {"--static-holds", [&] { f.static_holds = g.static_holds; }},
        {"--seed-transitions", [&] { f.seed_transitions = g.seed_transitions; }},
        {"--seed-expert", [&] { f.seed_expert = g.seed_expert; }},
        {"--bc-coef", [&] { f.fb.bc_coef = g.fb.bc_coef; }},
        {"--lr-actor", [&] { f.fb.lr_actor = g.fb.lr_actor; }},
        {"--no-dagger", [&] { f.dagger = g.dagger; }},
        {"--total-updates", [&] { f.total_updates = g.total_updates; }},
        {"--offline-updates", [&] { f.offline_updates = g.offline_updates; }},
        {"--envs", [&] { f.envs = g.envs; }},
        {"--batch", [&] { f.batch = g.batch; }},
        {"--bc-batch", [&] { f.bc_batch = g.bc_batch; }},
        {"--hidden", [&] { f.fb.hidden = g.fb.hidden; }},
        {"--z-dim", [&] { f.fb.z_dim = g.fb.z_dim; }},
        {"--track-window", [&] { f.fb.track_window = g.fb.track_window; }},
        {"--collect-every", [&] { f.collect_every = g.collect_every; }},
        {"--online-capacity", [&] { f.online_capacity = g.online_capacity; }},
        {"--demos", [&] { f.demo_dir = g.demo_dir; }},
        {"--demo-fraction", [&] { f.demo_fraction = g.demo_fraction; }}};
    for (const auto& [flag, set] : flags)
      if (app->count(flag) > 0) set();
  }
  cfg.validate();
  if (!cfg.demo_dir.empty())  // --demos DIR[,DIR...]: checked before any file is written
    for (const std::string& d : bfm::demo_directories(cfg.demo_dir))
      if (!fs::is_directory(d)) throw Error("train bfm: --demos: no directory '" + d + "'");
  t2m::nn::write_file_atomic(cfg_path, cfg.to_json().dump(1) + "\n");

  const std::string mpath =
      a.manifest.empty() ? t2m::data::default_cache_dir() + "/bandai/manifest.json" : a.manifest;
  if (!fs::exists(mpath)) throw Error("train bfm: no manifest at " + mpath + " (run `t2m data prepare`)");
  const auto manifest = t2m::data::load_manifest(mpath);
  auto h = t2m::sim::Humanoid::create();
  auto t0 = clock::now();
  bfm::RefMotions refs = bfm::load_ref_motions(*h, manifest, t2m::data::Split::train, cfg.ref_clips);
  std::fprintf(stderr, "train bfm: %d training clips (%lld frames) retargeted in %.1f s\n", refs.clips(),
               (long long)refs.total_frames(), std::chrono::duration<double>(clock::now() - t0).count());
  if (cfg.static_holds > 0) {  // standing-still references: first poses the balance expert can hold, + qpos0
    t0 = clock::now();
    const int F = cfg.max_episode_steps + 1;
    const std::vector<int> ok = bfm::holdable_start_clips(h, refs, F);
    std::vector<int> chosen;
    for (int i : bfm::spread_indices((int)ok.size(), cfg.static_holds)) chosen.push_back(ok[(size_t)i]);
    bfm::append_static_holds(refs, refs, *h, chosen, F);
    std::fprintf(stderr,
                 "train bfm: the balance expert holds %zu of %d first poses still for %d frames; + %zu standing-still "
                 "references (qpos0 and %zu of those; %lld frames in all) in %.1f s\n",
                 ok.size(), refs.clips() - (int)chosen.size() - 1, F, chosen.size() + 1, chosen.size(),
                 (long long)refs.total_frames(), std::chrono::duration<double>(clock::now() - t0).count());
  }

  bfm::BfmTrainer tr(cfg, h, refs, dir);
  if (tr.resumed()) std::fprintf(stderr, "train bfm: resumed %s at update %lld\n", dir.c_str(), (long long)tr.step());
  if (a.export_only) {  // the saved state's policy, nothing trained or written in DIR
    if (!tr.resumed()) throw Error("train bfm: --export-only needs a saved state in " + dir);
    if (a.export_path.empty()) throw Error("train bfm: --export-only needs --export PATH");
    export_policy(tr, cfg, a.export_path);
    return;
  }
  {
    t0 = clock::now();
    std::unique_ptr<t2m::nn::Progress> bar;  // only when the seed buffer is collected (not loaded)
    bool collected = false;
    tr.prepare_seed([&](int64_t done, int64_t total) {
      if (!bar) bar = std::make_unique<t2m::nn::Progress>(total, "seed data");
      collected = true;
      bar->update(done);
    });
    if (bar) bar->finish();
    const double s = std::chrono::duration<double>(clock::now() - t0).count();
    if (collected)
      std::fprintf(stderr, "train bfm: %lld seed transitions (noisy %s expert) in %.1f s = %.0f transitions/s\n",
                   (long long)cfg.seed_transitions, cfg.seed_expert.c_str(), s, cfg.seed_transitions / std::max(s, 1e-9));
    if (const auto* d = tr.demo_buffer()) {
      int owned = 0;
      for (char o : tr.planner_owned()) owned += o;
      std::fprintf(stderr,
                   "train bfm: %lld demonstration rows from %d planner runs in %s (%d unfinished, %d files not naming "
                   "a training clip); %d of %d reference clips are the planner's (no expert labels cloned there)\n",
                   (long long)d->size(), tr.demo_files(), cfg.demo_dir.c_str(), tr.demo_failed(), tr.demo_skipped(),
                   owned, refs.clips());
    }
  }

  t2m::nn::TrainLog log(dir + "/log.jsonl", tr.step());
  t2m::nn::ProgressOptions po;
  po.start = tr.step();
  t2m::nn::Progress bar(cfg.total_updates, "train bfm", po);
  const int64_t stop = a.updates > 0 ? std::min(cfg.total_updates, tr.step() + a.updates) : cfg.total_updates;
  const auto run_start = clock::now();
  auto last_save = clock::now();
  const auto minutes_since = [&](clock::time_point t) {
    return std::chrono::duration<double>(clock::now() - t).count() / 60.0;
  };
  int64_t done_here = 0;
  while (tr.step() < stop && !(a.minutes > 0 && minutes_since(run_start) >= a.minutes)) {
    const bfm::BfmStepStats s = tr.train_step();
    ++done_here;
    const int64_t step = tr.step();
    if (step % a.log_every == 0 || s.collected) {
      json rec = {{"step", step},
                  {"fb_loss", s.fb.fb_loss},
                  {"ortho_loss", s.fb.ortho_loss},
                  {"actor_loss", s.fb.actor_loss},
                  {"bc_loss", s.fb.bc_loss},
                  {"q_mean", s.fb.q_mean}};
      if (s.collected) {
        rec["online_episode_steps"] = s.collect.mean_episode_steps();
        rec["online_fail_rate"] = s.collect.episodes ? (double)s.collect.failed / s.collect.episodes : 0.0;
      }
      log.write(rec);
    }
    bar.update(step, {{"fb", s.fb.fb_loss}, {"actor", s.fb.actor_loss}, {"bc", s.fb.bc_loss}});
    if (minutes_since(last_save) >= a.save_minutes) {
      tr.save();
      last_save = clock::now();
    }
  }
  bar.finish();
  tr.save();
  try {
    t2m::nn::SvgPlotOptions so;
    so.keys = {"fb_loss", "actor_loss", "bc_loss", "ortho_loss"};
    so.title = "t2m train bfm: losses (Bandai train split)";
    t2m::nn::write_loss_svg(dir + "/log.jsonl", dir + "/loss.svg", so);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "train bfm: no loss plot yet (%s)\n", e.what());
  }
  const double secs = std::chrono::duration<double>(clock::now() - run_start).count();
  std::printf("train bfm: %lld updates this run in %.1f s (%.2f updates/s), at %lld / %lld; state %s\n",
              (long long)done_here, secs, done_here / std::max(secs, 1e-9), (long long)tr.step(),
              (long long)cfg.total_updates, tr.state_path().c_str());
  if (!a.export_path.empty()) export_policy(tr, cfg, a.export_path);
  std::fprintf(stderr, "train bfm: total wall %.1f s\n", std::chrono::duration<double>(clock::now() - t_start).count());
}

void add_train_bfm(CLI::App& app) {
  auto* g = t2m::cli::command_group(app, "train", "train a model");
  auto* c = g->add_subcommand("bfm", "train the behavior foundation model (FB agent) in resumable chunks");
  static TrainBfmArgs a;
  auto& cfg = a.cfg;
  c->add_option("--out", a.out, "run directory (default ~/.cache/t2m/bfm/default)");
  c->add_option("--manifest", a.manifest, "data manifest (default ~/.cache/t2m/bandai/manifest.json)");
  c->add_option("--minutes", a.minutes, "stop this invocation after M minutes (0 = no limit)");
  c->add_option("--updates", a.updates, "stop this invocation after N updates (0 = no limit)");
  c->add_option("--save-minutes", a.save_minutes, "checkpoint every M minutes")->capture_default_str();
  c->add_option("--log-every", a.log_every, "log line every N updates")->capture_default_str()->check(CLI::PositiveNumber);
  c->add_option("--threads", a.threads, "threads (0 = default); results are deterministic per thread count");
  c->add_option("--export", a.export_path, "write the policy checkpoint (actor + B + config) here at the end");
  c->add_flag("--export-only", a.export_only, "only write --export from the saved state (no training, DIR unchanged)");
  c->add_option("--seed", cfg.seed, "run seed")->capture_default_str();
  c->add_option("--total-updates", cfg.total_updates, "updates of the whole run")->capture_default_str();
  c->add_option("--offline-updates", cfg.offline_updates, "updates before online collection")->capture_default_str();
  c->add_option("--seed-transitions", cfg.seed_transitions, "noisy-expert seed transitions")->capture_default_str();
  c->add_option("--seed-expert", cfg.seed_expert,
                "seed-data and DAgger-label tracker: balance (PD + balance feedback) | balance-hips (its root torque "
                "through the stance hips only) | pd")
      ->capture_default_str()
      ->check(CLI::IsMember({"balance", "balance-hips", "pd"}));
  c->add_flag("--no-dagger{false}", cfg.dagger,
              "BC on the seed actions only (default: expert labels, half on the policy's relabelled online states)");
  c->add_option("--bc-coef", cfg.fb.bc_coef, "behaviour-cloning weight of the actor loss")->capture_default_str();
  c->add_option("--lr-actor", cfg.fb.lr_actor, "AdamW learning rate of the actor")->capture_default_str();
  c->add_option("--ref-clips", cfg.ref_clips, "training clips used (0 = all)")->capture_default_str();
  c->add_option("--static-holds", cfg.static_holds,
                "standing-still references: qpos0 + N first poses of clips that the balance expert holds (0 = none)")
      ->capture_default_str();
  c->add_option("--envs", cfg.envs, "parallel environments")->capture_default_str();
  c->add_option("--batch", cfg.batch, "FB batch")->capture_default_str();
  c->add_option("--bc-batch", cfg.bc_batch, "behaviour-cloning batch (0 = off)")->capture_default_str();
  c->add_option("--hidden", cfg.fb.hidden, "width of F and the actor")->capture_default_str();
  c->add_option("--z-dim", cfg.fb.z_dim, "latent dimension d")->capture_default_str();
  c->add_option("--track-window", cfg.fb.track_window,
                "window L of Eq 2 for the tracking latents (seed and online data, BC rows, eval)")
      ->capture_default_str();
  c->add_option("--collect-every", cfg.collect_every, "updates between online rounds")->capture_default_str();
  c->add_option("--online-capacity", cfg.online_capacity, "online replay capacity")->capture_default_str();
  c->add_option("--demos", cfg.demo_dir,
                "planner demonstrations: a `t2m track-pd --samcon-mpc --export-dir` directory (NAME.ctrl.json of "
                "training clips), or several separated by commas (e.g. planner runs, then DAgger runs with "
                "--mpc-student); their rows join the seed data with the planner's labels");
  c->add_option("--demo-fraction", cfg.demo_fraction,
                "with --demos: share of the seed rows of each batch drawn from the demonstrations")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  c->callback([c] { run_train_bfm(a, c); });
}

}  // namespace

T2M_COMMAND(add_train_bfm);
