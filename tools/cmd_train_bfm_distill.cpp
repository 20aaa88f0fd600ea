// cmd_train_bfm_distill.cpp — `t2m train bfm-distill`: the z search distilled into the actor (models/bfm/
// search_distill.h, docs/BFM.md "Session 27"), in resumable chunks.
//   t2m train bfm-distill --policy P --out DIR [--contents raise-up,wave] [--every K [--offset O]]
//       [--chunk-clips 40] [--max-chunks C] [--minutes M] [--search-samples 64 --search-horizon 5
//       --search-sigma 0.3 --elites 8 --action-noise 0.03 --search-seed 1] [--anchor-clips 400 --anchor-noise 0.05
//       --anchor-weight 1 --updates 6000 --lr 1e-4 --batch 256 --fit-seed 7] [--anchor-all] [--threads T]
//       [--export OUT.t2mckpt [--fit-partial]] [--with-rows EARLIER_DIR ...]
//       [--standing-start [--transition-frames 30] [--transition-fail-distance 1.0]]
// Stage 1 (collection): the train clips whose content label starts with one of --contents (every K-th from the
// O-th, name order; with --max-chunks only the first C chunks) are tracked by the z search of P with action
// noise, in chunks of --chunk-clips clips; chunk k is written to DIR/rows_NNNNN.t2mckpt (NNNNN = its first clip)
// atomically and skipped when present, so an interrupted or
// --minutes-limited run resumes at the first missing chunk. Clip i of the selection uses search seed + i.
// Stage 2 (once every chunk exists, or with --fit-partial on the chunks present, and --export is given): anchor
// rows from plain Eq 2 rollouts of P on the train clips of the other contents (--anchor-clips spread over the
// split), the actor fit on this round's rows and those of --with-rows (earlier rounds: DAgger aggregation), the
// policy written to OUT.
// --standing-start (session 47): every searched rollout starts at qpos0 at rest, where generations start, with the
// reference moved to start there and a relaxed fail distance for the first frames (latent_search.h): rows of the
// transition from standing into each motion. --anchor-all: the anchor rows come from train clips of every content,
// the searched ones included (from their first state), so that a round fitted without earlier rounds' rows keeps
// the policy's own tracking of them.
// DIR/config.json holds the selection and search options of the first invocation; later ones must agree.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/bfm/latent_search.h"
#include "models/bfm/policy_checkpoint.h"
#include "models/bfm/ref_motions.h"
#include "models/bfm/search_distill.h"
#include "models/data/dataset.h"
#include "models/data/splits.h"
#include "nn/progress.h"
#include "tensor/parallel.h"
#include "tools/command.h"

namespace {

using t2m::Error;
using json = nlohmann::json;
namespace fs = std::filesystem;
namespace bfm = t2m::bfm;
namespace data = t2m::data;

struct DistillArgs {
  std::string policy = "models/checkpoints/bfm_track.t2mckpt", out, manifest, export_path, contents = "raise-up,wave";
  std::vector<std::string> with_rows;  // earlier rounds' row directories, fitted too (DAgger aggregation)
  int every = 1, offset = 0, max_chunks = 0, chunk_clips = 40, anchor_clips = 400, threads = 0;
  double minutes = 0, anchor_noise = 0.05;
  bool fit_partial = false, standing_start = false, anchor_all = false;
  bfm::LatentSearchOptions search;
  bfm::DistillOptions fit;
  DistillArgs() {
    search.elites = 8;
    search.action_noise = 0.03;
  }
};

std::vector<std::string> split_list(const std::string& s) {
  std::vector<std::string> out;
  size_t p = 0;
  while (p <= s.size()) {
    const size_t q = std::min(s.find(',', p), s.size());
    if (q > p) out.push_back(s.substr(p, q - p));
    p = q + 1;
  }
  return out;
}

bool has_content(const std::string& label, const std::vector<std::string>& prefixes) {
  for (const auto& p : prefixes)
    if (label.rfind(p, 0) == 0) return true;
  return false;
}

// The manifest restricted to clips whose content label does (keep = true) or does not start with a prefix.
data::Manifest by_content(const data::Manifest& m, const std::vector<std::string>& prefixes, bool keep) {
  data::Manifest f = m;
  f.clips.clear();
  for (const auto& c : m.clips)
    if (has_content(c.content_label, prefixes) == keep) f.clips.push_back(c);
  return f;
}

std::string chunk_path(const std::string& dir, int first) {
  char name[32];
  std::snprintf(name, sizeof name, "/rows_%05d.t2mckpt", first);
  return dir + name;
}

// The rows_*.t2mckpt files of an earlier round's directory, name order; none is an error.
std::vector<std::string> row_files(const std::string& dir) {
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".t2mckpt" && e.path().filename().string().rfind("rows_", 0) == 0)
      files.push_back(e.path().string());
  if (files.empty()) throw Error("train bfm-distill: --with-rows " + dir + " holds no rows_*.t2mckpt");
  std::sort(files.begin(), files.end());
  return files;
}

void run_distill(const DistillArgs& a) {
  const auto t0 = std::chrono::steady_clock::now();
  if (a.threads > 0) t2m::set_num_threads(a.threads);
  const std::vector<std::string> contents = split_list(a.contents);
  if (contents.empty()) throw Error("train bfm-distill: --contents names no content label");
  const std::string dir = a.out.empty() ? data::default_cache_dir() + "/bfm/distill" : a.out;
  json cfg = {{"policy", a.policy},          {"contents", a.contents},          {"every", a.every},
              {"chunk_clips", a.chunk_clips}, {"samples", a.search.samples},     {"window", a.search.window},
              {"horizon", a.search.horizon},  {"sigma", a.search.sigma},         {"carry", a.search.carry},
              {"elites", a.search.elites},    {"action_noise", a.search.action_noise},
              {"seed", a.search.seed}};
  if (a.offset >= a.every) throw Error("train bfm-distill: --offset must be below --every");
  if (a.offset > 0) cfg["offset"] = a.offset;  // absent when 0: directories of earlier builds stay valid
  bfm::LatentSearchOptions search = a.search;
  if (a.standing_start) {  // likewise absent without it
    search.start = bfm::TrackStart::standing;
    cfg["start"] = "standing";
    cfg["transition"] = search.transition;
    cfg["transition_fail_distance"] = search.transition_fail_distance;
  }
  bfm::check_search_options(search);
  auto agent = bfm::load_policy(a.policy);  // before touching DIR: a bad policy leaves nothing behind
  std::vector<std::vector<std::string>> earlier;  // --with-rows files, checked before the long search
  for (const std::string& d2 : a.with_rows) earlier.push_back(row_files(d2));
  const std::string manifest_path =
      a.manifest.empty() ? data::default_cache_dir() + "/bandai/manifest.json" : a.manifest;
  const data::Manifest manifest = data::load_manifest(manifest_path);
  fs::create_directories(dir);
  const std::string cfg_path = dir + "/config.json";
  if (fs::exists(cfg_path)) {
    json old;
    std::ifstream(cfg_path) >> old;
    if (old != cfg)
      throw Error("train bfm-distill: " + cfg_path + " was written with other options (" + old.dump() +
                  "); use another --out");
  } else {
    std::ofstream(cfg_path + ".tmp") << cfg.dump(1) << "\n";
    fs::rename(cfg_path + ".tmp", cfg_path);
  }

  auto h = t2m::sim::Humanoid::create();
  const bfm::RefMotions all = bfm::load_ref_motions(*h, by_content(manifest, contents, true), data::Split::train, 0);
  bfm::RefMotions sel;
  for (int c = a.offset; c < all.clips(); c += a.every) sel.add(*h, all.names[c], all.trajectory(c));
  const int n = sel.clips(), all_chunks = (n + a.chunk_clips - 1) / a.chunk_clips;
  const int chunks = a.max_chunks > 0 ? std::min(a.max_chunks, all_chunks) : all_chunks;  // the first ones only
  std::fprintf(stderr, "train bfm-distill: %d train clips of %s (every %d from %d), %d chunks of %d in %s\n", n,
               a.contents.c_str(), a.every, a.offset, chunks, a.chunk_clips, dir.c_str());
  int done = 0;
  for (int k = 0; k < chunks; ++k) done += fs::exists(chunk_path(dir, k * a.chunk_clips));
  t2m::nn::ProgressOptions po;
  po.start = done;
  t2m::nn::Progress bar(chunks, "train bfm-distill: search chunks", po);
  const auto minutes = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / 60.0;
  };
  for (int k = 0; k < chunks && !(a.minutes > 0 && minutes() >= a.minutes); ++k) {
    const int first = k * a.chunk_clips, last = std::min(n, first + a.chunk_clips);
    if (fs::exists(chunk_path(dir, first))) continue;
    bfm::RefMotions part;
    std::vector<std::string> names;
    for (int c = first; c < last; ++c) part.add(*h, sel.names[c], sel.trajectory(c)), names.push_back(sel.names[c]);
    bfm::LatentSearchOptions so = search;
    so.seed = a.search.seed + (uint64_t)first;  // clip i of the selection: seed + i
    bfm::SearchRows rows;
    const auto res = bfm::track_bfm_search(*agent, h, part, so, {}, 0, &rows);
    int tracked = 0;
    for (const auto& r : res) tracked += r.success;
    bfm::save_search_rows(rows, names, chunk_path(dir, first), {{"first_clip", first}, {"tracked", tracked}});
    bar.update(++done, {{"tracked", (double)tracked / (last - first)}});
  }
  bar.finish();
  if (done < chunks)
    std::printf("train bfm-distill: %d of %d chunks in %s; run again to continue\n", done, chunks, dir.c_str());
  else
    std::printf("train bfm-distill: all %d chunks in %s\n", chunks, dir.c_str());
  if (a.export_path.empty() || (done < chunks && !a.fit_partial) || done == 0) return;

  const int D = agent->config().obs_dim, d = agent->config().z_dim, A = agent->config().action_dim;
  bfm::SearchRows labels;
  const auto append_file = [&](const std::string& path, int first_clip) {  // -> clips in the file
    std::vector<std::string> names;
    bfm::append_search_rows(labels, bfm::load_search_rows(path, D, d, A, &names), first_clip);
    return (int)names.size();
  };
  int used = 0;
  for (int k = 0; k < chunks; ++k)
    if (fs::exists(chunk_path(dir, k * a.chunk_clips)))  // all of them unless --fit-partial
      append_file(chunk_path(dir, k * a.chunk_clips), k * a.chunk_clips), ++used;
  int extra = 0;  // rows of earlier rounds: clip ids moved past this round's
  for (const auto& files : earlier)
    for (const std::string& f : files) extra += append_file(f, n + extra);
  const bfm::RefMotions others = bfm::load_ref_motions(
      *h, a.anchor_all ? manifest : by_content(manifest, contents, false), data::Split::train, a.anchor_clips);
  const bfm::SearchRows anchor = bfm::plain_tracking_rows(*agent, h, others, a.anchor_noise, a.search.seed);
  std::fprintf(stderr, "train bfm-distill: %lld label rows, %lld anchor rows (%d clips of %s)\n",
               (long long)labels.rows(), (long long)anchor.rows(), others.clips(),
               a.anchor_all ? "every content" : "other contents");
  t2m::nn::Progress fbar(a.fit.updates, "train bfm-distill: fit");
  const bfm::DistillStats st = bfm::fit_actor_to_search(
      *agent, labels, anchor, a.fit, [&](int64_t u, double loss) { fbar.update(u, {{"loss", loss}}); });
  fbar.finish();
  std::printf("train bfm-distill: RMS to the search's actions %.4f -> %.4f, to the anchor %.4f -> %.4f\n",
              st.label_rms_before, st.label_rms_after, st.anchor_rms_before, st.anchor_rms_after);
  if (const fs::path p(a.export_path); p.has_parent_path()) fs::create_directories(p.parent_path());
  json info = cfg;
  info["with_rows"] = a.with_rows;
  info["fit"] = {{"chunks", used},         {"of_chunks", chunks}, {"updates", a.fit.updates},
                 {"lr", a.fit.lr},         {"batch", a.fit.batch},  {"seed", a.fit.seed},
                 {"anchor_weight", a.fit.anchor_weight}, {"anchor_clips", a.anchor_clips},
                 {"anchor_noise", a.anchor_noise}, {"anchor_all", a.anchor_all}, {"max_chunks", a.max_chunks},
                 {"label_rows", labels.rows()}, {"anchor_rows", anchor.rows()}};
  info["data"] = "Bandai-Namco-Research-Motiondataset (CC BY-NC 4.0), train split";
  bfm::save_policy(*agent, a.export_path, info);
  std::printf("wrote %s (actor fine-tuned on the z search of %s)\n", a.export_path.c_str(), a.policy.c_str());
}

void add_train_bfm_distill(CLI::App& app) {
  auto* g = t2m::cli::command_group(app, "train", "train a model");
  static DistillArgs a;
  auto* c = g->add_subcommand("bfm-distill", "distil the evaluation-time z search into the BFM's actor (resumable)");
  c->add_option("--policy", a.policy, "BFM policy searched and fine-tuned")->capture_default_str();
  c->add_option("--out", a.out, "directory of the searched rows (default ~/.cache/t2m/bfm/distill)");
  c->add_option("--manifest", a.manifest, "data manifest (default ~/.cache/t2m/bandai/manifest.json)");
  c->add_option("--contents", a.contents, "content-label prefixes of the searched train clips, comma-separated")
      ->capture_default_str();
  c->add_option("--every", a.every, "every K-th of those clips (name order)")->capture_default_str()->check(CLI::PositiveNumber);
  c->add_option("--offset", a.offset, "start at the offset-th clip (0 <= offset < every: a disjoint selection)")
      ->capture_default_str()->check(CLI::NonNegativeNumber);
  c->add_option("--with-rows", a.with_rows, "earlier rounds' row directories, fitted with this one's (repeatable)")
      ->check(CLI::ExistingDirectory);
  c->add_option("--max-chunks", a.max_chunks, "search and fit only the first K chunks (0 = all; a shorter round)")
      ->capture_default_str()->check(CLI::NonNegativeNumber);
  c->add_option("--chunk-clips", a.chunk_clips, "clips per rows file")->capture_default_str()->check(CLI::PositiveNumber);
  c->add_option("--minutes", a.minutes, "start no new chunk after M minutes (0 = no limit)");
  c->add_option("--search-samples", a.search.samples, "z search: candidates per window")->capture_default_str();
  c->add_option("--search-horizon", a.search.horizon, "z search: look-ahead in 0.1 s windows")->capture_default_str();
  c->add_option("--search-sigma", a.search.sigma, "z search: std of the offset's step")->capture_default_str();
  c->add_option("--search-seed", a.search.seed, "z search: seed (clip i of the selection: seed + i)")->capture_default_str();
  c->add_option("--elites", a.search.elites, "z search: offsets averaged into the applied one")->capture_default_str();
  c->add_option("--action-noise", a.search.action_noise, "std of the noise on the searched body's actions")
      ->capture_default_str();
  c->add_option("--anchor-clips", a.anchor_clips, "train clips of the other contents for the anchor rows (spread)")
      ->capture_default_str()->check(CLI::PositiveNumber);
  c->add_option("--anchor-noise", a.anchor_noise, "action noise of the anchor rollouts")->capture_default_str();
  c->add_option("--anchor-weight", a.fit.anchor_weight, "weight of the anchor term")->capture_default_str();
  c->add_flag("--anchor-all", a.anchor_all, "anchor rows from train clips of every content, the searched ones too");
  c->add_flag("--standing-start", a.standing_start,
              "search from qpos0 at rest (where generations start), the reference moved to start there");
  c->add_option("--transition-frames", a.search.transition,
                "standing start: frames during which a body may be --transition-fail-distance off")
      ->capture_default_str()->check(CLI::NonNegativeNumber);
  c->add_option("--transition-fail-distance", a.search.transition_fail_distance,
                "standing start: the fail distance (m) of those frames")->capture_default_str();
  c->add_option("--updates", a.fit.updates, "fit: AdamW updates")->capture_default_str()->check(CLI::PositiveNumber);
  c->add_option("--lr", a.fit.lr, "fit: peak learning rate (cosine to 0)")->capture_default_str();
  c->add_option("--batch", a.fit.batch, "fit: rows of each kind per update")->capture_default_str()->check(CLI::PositiveNumber);
  c->add_option("--fit-seed", a.fit.seed, "fit: seed of the batch sampling")->capture_default_str();
  c->add_option("--threads", a.threads, "threads (0 = default); results are deterministic per thread count");
  c->add_option("--export", a.export_path, "when every chunk exists: fit and write the fine-tuned policy here");
  c->add_flag("--fit-partial", a.fit_partial, "with --export: fit on the chunks present even if some are missing");
  c->callback([] { run_distill(a); });
}

}  // namespace

T2M_COMMAND(add_train_bfm_distill);
