// cmd_eval_track.cpp — `t2m eval track`: motion tracking on held-out clips, the BFM (z_t from Eq 2 on the
// reference, roll out the policy mean) and the PD baseline side by side, with the same metrics
// (sim::TrackingScorer), plus the Eq 21 action KL between the Eq 2 latent sequences at two window lengths.
//   t2m eval track [--policy models/checkpoints/bfm_small.t2mckpt] [--split test] [--clips N] [--kl-window 4]
//                  [--track-window L] [--no-pd] [--expert [--torque-at-hips-only]] [--stand SECONDS] [--threads T]
//                  [--z-search [--search-samples 64] [--search-horizon 5] [--search-sigma 0.3] [--search-seed 1]]
//                  [--out RESULT.json]
// --z-search: one more row, "BFM + z search": the same policy driven by an evaluation-time planner over its
// latent (bfm::track_bfm_search; it simulates candidates ahead, so it is a planner, reported apart from the BFM row).
// --clips N: N clips spread evenly over the split (sorted by name, fixed stride), 0 = all.
// --stand S: standing still instead of the clips: qpos0 and the first frame of every selected clip, each held
// still for S seconds (bfm::append_static_holds; z = Eq 2 on a static reference = B(s) of the pose).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <numeric>
#include <nlohmann/json.hpp>
#include <string>

#include "models/bfm/latent_search.h"
#include "models/bfm/policy_checkpoint.h"
#include "models/bfm/track_eval.h"
#include "models/data/dataset.h"
#include "nn/checkpoint.h"
#include "sim/skeleton.h"
#include "tensor/parallel.h"
#include "tools/command.h"

namespace {

using t2m::Error;
using json = nlohmann::json;
namespace fs = std::filesystem;
namespace bfm = t2m::bfm;

struct EvalTrackArgs {
  std::string policy = "models/checkpoints/bfm_small.t2mckpt";
  std::string manifest, split = "test", out;
  int clips = 0, threads = 0, kl_window = 4, track_window = 0;
  double stand_s = 0;
  bool no_pd = false;
  bool expert = false;
  bool hips_only = false;  // the expert's root torque through the stance hips only (--seed-expert balance-hips)
  bool z_search = false;   // also the BFM with an evaluation-time search over z (models/bfm/latent_search.h)
  bfm::LatentSearchOptions search;
};

json rows_json(const bfm::RefMotions& refs, const std::vector<t2m::sim::PdResult>& r) {
  json rows = json::array();
  for (size_t c = 0; c < r.size(); ++c)
    rows.push_back({{"name", refs.names[c]},
                    {"frames", r[c].frames},
                    {"success", r[c].success},
                    {"fell", r[c].fell},
                    {"mpjpe_m", r[c].mpjpe_m},
                    {"root_drift_m", r[c].root_drift_m},
                    {"frames_ok", r[c].frames_ok}});
  return rows;
}

void print_row(const char* who, const json& s) {
  std::printf("%-17s success %5.1f%%  fall %5.1f%%  MPJPE %7.1f mm  root drift %5.2f m  frames tracked %5.1f%%\n", who,
              100 * s["success_rate"].get<double>(), 100 * s["fall_rate"].get<double>(),
              1e3 * s["mpjpe_m"].get<double>(), s["root_drift_m"].get<double>(),
              100 * s["mean_fraction_of_frames_tracked"].get<double>());
}

void run_eval_track(const EvalTrackArgs& a) {
  using clock = std::chrono::steady_clock;
  if (a.threads > 0) t2m::set_num_threads(a.threads);
  if (a.clips < 0) throw Error("eval track: --clips must be >= 0");
  if (a.kl_window < 1) throw Error("eval track: --kl-window must be >= 1");
  if (a.track_window < 0) throw Error("eval track: --track-window must be >= 0 (0 = the policy's own window)");
  if (a.z_search) bfm::check_search_options(a.search);
  if (!fs::exists(a.policy)) throw Error("eval track: no policy file '" + a.policy + "' (train one with `t2m train bfm --export`)");
  json info;
  auto agent = bfm::load_policy(a.policy, &info);
  const t2m::data::Split split = t2m::data::split_from_name(a.split);
  const std::string mpath =
      a.manifest.empty() ? t2m::data::default_cache_dir() + "/bandai/manifest.json" : a.manifest;
  if (!fs::exists(mpath)) throw Error("eval track: no manifest at " + mpath + " (run `t2m data prepare`)");
  auto h = t2m::sim::Humanoid::create();
  if (!(a.stand_s >= 0) || a.stand_s > 120) throw Error("eval track: --stand must be in [0, 120] seconds");
  const t2m::data::Manifest manifest = t2m::data::load_manifest(mpath);
  bfm::RefMotions refs = bfm::load_ref_motions(*h, manifest, split, a.clips);
  // Each clip's content label (walk, run, wave-right-hand, ...) for the per-content breakdown (not with --stand).
  std::vector<std::string> content;
  if (a.stand_s <= 0) {
    std::map<std::string, std::string> label;
    for (const auto& ci : manifest.clips) label[ci.name] = ci.content_label;
    for (const auto& n : refs.names) content.push_back(label.count(n) ? label[n] : "?");
  }
  json by_content = json::object();
  if (a.stand_s > 0) {
    bfm::RefMotions holds;
    std::vector<int> every_clip((size_t)refs.clips());
    std::iota(every_clip.begin(), every_clip.end(), 0);
    bfm::append_static_holds(holds, refs, *h, every_clip, std::max(2, (int)std::lround(a.stand_s * 30)));
    refs = std::move(holds);
  }
  char stand_label[64];
  std::snprintf(stand_label, sizeof stand_label, "standing-still poses (%g s each)", a.stand_s);
  const std::string what = a.stand_s > 0 ? stand_label : "clips";
  std::fprintf(stderr, "eval track: %d %s %s (%lld frames)\n", refs.clips(), a.split.c_str(), what.c_str(),
               (long long)refs.total_frames());
  auto t0 = clock::now();
  const int track_window = a.track_window > 0 ? a.track_window : agent->config().track_window;
  const auto bfm_res = bfm::track_bfm(*agent, h, refs, {}, track_window);
  const double bfm_s = std::chrono::duration<double>(clock::now() - t0).count();
  const json bs = bfm::summarize_tracking(bfm_res);
  if (!content.empty()) by_content["bfm"] = bfm::summarize_tracking_by_group(bfm_res, content);
  json result = {{"command", a.stand_s > 0 ? "eval track --stand" : "eval track"},
                 {"data", "Bandai-Namco-Research-Motiondataset (CC BY-NC 4.0), split " + a.split},
                 {"policy", a.policy},
                 {"policy_info", info},
                 {"track_window", track_window},
                 {"bfm", bs},
                 {"bfm_seconds", bfm_s}};
  if (a.stand_s > 0) result["stand_seconds"] = a.stand_s;
  std::printf("eval track (%s split, %d %s, no assist; BFM latents: Eq 2 with L = %d):\n", a.split.c_str(),
              refs.clips(), what.c_str(), track_window);
  print_row("BFM", bs);
  // A baseline controller's row: summary, wall time and per-clip rows under `key`.
  const auto baseline_row = [&](const char* label, const std::string& key, auto track_all) {
    t0 = clock::now();
    const auto res = track_all();
    const json s = bfm::summarize_tracking(res);
    result[key] = s;
    result[key + "_seconds"] = std::chrono::duration<double>(clock::now() - t0).count();
    result[key + "_clips"] = rows_json(refs, res);
    if (!content.empty()) by_content[key] = bfm::summarize_tracking_by_group(res, content);
    print_row(label, s);
  };
  if (a.z_search)  // the policy with an evaluation-time planner over z (not the policy's own tracking)
    baseline_row("BFM + z search", "bfm_search",
                 [&] { return bfm::track_bfm_search(*agent, h, refs, a.search, {}, track_window); });
  if (!a.no_pd) baseline_row("PD", "pd", [&] { return bfm::track_pd_all(h, refs); });
  t2m::sim::BalanceOptions bal;
  bal.torque_at_hips_only = a.hips_only;
  if (a.expert) {  // the teacher's row, and the student's imitation error against it on the reference states
    result["expert_torque_at_hips_only"] = a.hips_only;
    baseline_row(a.hips_only ? "PD+balance expert (hips)" : "PD+balance expert", "balance_expert",
                 [&] { return bfm::track_balance_all(h, refs, bal); });
    const std::vector<double> rms = bfm::expert_imitation_rms(*agent, h, refs, bal);
    double all = 0, ankles = 0;
    for (double r : rms) all += r * r;
    for (int j : {t2m::sim::kFootL, t2m::sim::kFootR})
      for (int i = 0; i < 3; ++i) ankles += rms[(size_t)(3 * (j - 1) + i)] * rms[(size_t)(3 * (j - 1) + i)];
    all = std::sqrt(all / rms.size());
    ankles = std::sqrt(ankles / 6);
    result["expert_imitation_rms"] = {{"all", all}, {"ankles", ankles}, {"per_actuator", rms}};
    std::printf("imitation RMS vs the balance expert's action on the reference states ([-1, 1] units): %.4f (ankles %.4f)\n",
                all, ankles);
  }
  if (!content.empty()) {  // success and frames tracked per content label, one column per controller
    result["by_content"] = by_content;
    std::printf("by content label (success %% / frames tracked %%):\n%-22s %5s", "content", "clips");
    for (const auto& [who, _] : by_content.items()) std::printf("  %-17s", who.c_str());
    std::printf("\n");
    for (const auto& [g, s] : by_content["bfm"].items()) {
      std::printf("%-22s %5d", g.c_str(), s["clips"].get<int>());
      for (const auto& [who, groups] : by_content.items())
        std::printf("  %5.1f / %5.1f    ", 100 * groups[g]["success_rate"].get<double>(),
                    100 * groups[g]["mean_fraction_of_frames_tracked"].get<double>());
      std::printf("\n");
    }
  }
  const std::vector<double> kl = bfm::window_action_kl(*agent, refs, a.kl_window);
  double kl_mean = 0;
  for (double k : kl) kl_mean += k;
  kl_mean /= std::max<size_t>(kl.size(), 1);
  result["action_kl_eq21"] = {{"z", "Eq 2, L = " + std::to_string(agent->config().track_window)},
                              {"z_hat", "Eq 2, L = " + std::to_string(a.kl_window)},
                              {"mean_over_clips", kl_mean}};
  result["bfm_clips"] = rows_json(refs, bfm_res);
  std::printf("Eq 21 action KL(z_hat L=%d || z L=%d) on the reference states: %.4f (mean over clips)\n", a.kl_window,
              agent->config().track_window, kl_mean);
  if (!a.out.empty()) {
    t2m::nn::write_file_atomic(a.out, result.dump(1) + "\n");
    std::printf("wrote %s\n", a.out.c_str());
  }
}

void add_eval_track(CLI::App& app) {
  auto* g = t2m::cli::command_group(app, "eval", "evaluate a model");
  auto* c = g->add_subcommand("track", "BFM vs PD motion tracking on held-out clips (success, MPJPE, falls)");
  static EvalTrackArgs a;
  c->add_option("--policy", a.policy, "BFM policy checkpoint (actor + B)")->capture_default_str();
  c->add_option("--manifest", a.manifest, "data manifest (default ~/.cache/t2m/bandai/manifest.json)");
  c->add_option("--split", a.split, "train | val | test")->capture_default_str();
  c->add_option("--clips", a.clips, "evaluate N clips spread over the split (0 = all)")->capture_default_str();
  c->add_option("--kl-window", a.kl_window, "window L of z_hat for the Eq 21 action KL")->capture_default_str();
  c->add_option("--track-window", a.track_window,
                "window L of Eq 2 for the BFM's tracking latents (0 = the policy's own, 8 for the shipped ones)")
      ->capture_default_str();
  c->add_flag("--no-pd", a.no_pd, "skip the PD baseline");
  c->add_option("--stand", a.stand_s,
                "standing still for SECONDS instead of the clips: qpos0 and each clip's first pose held still")
      ->capture_default_str();
  CLI::Option* expert =
      c->add_flag("--expert", a.expert, "also run the balance-feedback expert the BFM's seed data comes from");
  c->add_flag("--torque-at-hips-only", a.hips_only,
              "the expert (--expert) applies its root torque through the stance hips only: the teacher of "
              "`train bfm --seed-expert balance-hips`")
      ->needs(expert);
  CLI::Option* zs = c->add_flag(
      "--z-search", a.z_search,
      "also the BFM with an evaluation-time search over z: per 0.1 s window, candidate offsets to the Eq 2 latents "
      "simulated ahead with the policy, the best tracking one applied (models/bfm/latent_search.h; a planner, slow: "
      "~10 s per 3 s clip on 2 threads)");
  c->add_option("--search-samples", a.search.samples, "z search: candidates per window")->capture_default_str()->needs(zs);
  c->add_option("--search-horizon", a.search.horizon, "z search: look-ahead in 0.1 s windows")
      ->capture_default_str()
      ->needs(zs);
  c->add_option("--search-sigma", a.search.sigma, "z search: std of the offset's step per latent coordinate")
      ->capture_default_str()
      ->needs(zs);
  c->add_option("--search-seed", a.search.seed, "z search: seed (clip c uses seed + c)")->capture_default_str()->needs(zs);
  c->add_option("--threads", a.threads, "threads (0 = default)");
  c->add_option("--out", a.out, "write the JSON result here (atomic)");
  c->callback([] { run_eval_track(a); });
}

}  // namespace

T2M_COMMAND(add_eval_track);
