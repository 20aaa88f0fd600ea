// cmd_data_posescripts.cpp — `t2m data posescripts`: our PoseScript-style set (PRO-Motion posture scripts of the
// key poses of one split of the Bandai data, models/promotion/posture_script_set.h) for inspection: prints the
// scripts of the first --limit key poses, optionally the posecode statistics (--stats) and a JSONL file (--out).
// --agreement N: the posture diffuser's posecode agreement on N scripts of the split (--sample samples each,
// default 4; --sampler-steps, --eta, --guidance), against random train key poses (posture_agreement.h).
#include <chrono>
#include <cstdio>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "models/promotion/planner.h"
#include "models/promotion/pose.h"
#include "models/promotion/posture_agreement.h"
#include "models/promotion/posture_diffuser_sampler.h"
#include "models/promotion/posecodes.h"
#include "models/promotion/posture_script_set.h"
#include "tensor/parallel.h"
#include "tools/command.h"
#include "tools/text_data.h"

namespace {

using t2m::Error;
namespace pm = t2m::promotion;

struct Args {
  std::string split = "test", out, data_dir, cache_dir, plan, table = "models/checkpoints/promotion_planner.json";
  int limit = 5, keys = pm::kDefaultKeyFrames, threads = 0, sample = 0, agreement = 0;
  pm::PostureSampleOptions sampler;
  std::string posture = "models/checkpoints/promotion_posture.t2mckpt";
  bool mirror = false, stats = false;
};

void print_stats(const pm::PostureScriptSet& s) {
  const auto& rules = pm::posecode_rules();
  const auto f = pm::posecode_frequencies(s);
  std::printf("\nposecode statistics over %d key poses (share of poses per category; * = described in scripts)\n",
              s.size());
  for (size_t r = 0; r < rules.size(); ++r) {
    std::printf("  %-18s %-34s", pm::posecode_family_name(rules[r].family), rules[r].name.c_str());
    for (size_t c = 0; c < f[r].size(); ++c)
      std::printf(" %s%s %.3f", rules[r].described((int)c) ? "*" : "",
                  rules[r].categories[c].empty() ? "-" : rules[r].categories[c].c_str(), f[r][c]);
    std::printf("\n");
  }
  double words = 0;
  for (const auto& t : s.scripts) {
    int n = 1;
    for (char ch : t) n += ch == ' ';
    words += n;
  }
  std::printf("mean script length: %.1f words\n", s.size() ? words / s.size() : 0.0);
}

// --plan: the rule/template planner's clauses and key-frame scripts for one prompt (no data needed).
void run_plan(const Args& a) {
  const pm::PlannerTable t = pm::load_planner_table(a.table);
  const pm::Plan p = pm::plan_postures(t, a.plan, a.keys);
  for (const auto& c : p.clauses)
    std::printf("clause \"%s\": content %s, style %s, entry \"%s\"%s, %d key frames (similarity %.3f)\n",
                c.text.c_str(), c.content.empty() ? "(none: neutral pose)" : c.content.c_str(),
                c.style.empty() ? "-" : c.style.c_str(), c.entry.c_str(), c.mirrored ? ", mirrored" : "", c.frames,
                c.score);
  for (size_t i = 0; i < p.scripts.size(); ++i) std::printf("F%zu: %s\n", i + 1, p.scripts[i].c_str());
  if (a.sample < 1) return;
  // --sample N: N posture-diffuser candidates per key frame and their posecode agreement with the plan.
  if (a.threads > 0) t2m::set_num_threads(a.threads);
  const pm::PostureModel m = pm::load_posture_model(a.posture);
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<float> poses = pm::sample_postures(m, p.scripts, a.sample, 0, a.sampler);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  for (size_t i = 0; i < p.scripts.size(); ++i) {
    std::printf("F%zu agreement:", i + 1);
    for (int j = 0; j < a.sample; ++j)
      std::printf(" %.2f", pm::posecode_agreement(
                               p.codes[i], pm::pose_posecodes(poses.data() + (i * a.sample + j) * pm::kPoseDim)));
    std::printf("\n");
  }
  std::printf("sampled %zu x %d poses in %.1f s\n", p.scripts.size(), a.sample, secs);
}

void run(const Args& a) {
  if (!a.plan.empty()) return run_plan(a);
  if (a.limit < 0) throw Error("data posescripts: --limit must be >= 0, got " + std::to_string(a.limit));
  if (a.keys < 1) throw Error("data posescripts: --keys must be >= 1, got " + std::to_string(a.keys));
  if (a.threads > 0) t2m::set_num_threads(a.threads);
  const auto split = t2m::data::split_from_name(a.split);
  const auto d = t2m::cli::load_text_data({a.data_dir, a.cache_dir, a.threads});
  const auto clips = t2m::cli::split_clips(d, split, a.threads);
  const pm::PostureScriptSet s = pm::build_posture_script_set(clips, a.keys, a.mirror);
  std::printf("%s split: %zu clips, %d key poses (%d per clip%s); Bandai-Namco, scripts from our posecodes\n",
              a.split.c_str(), clips.size(), s.size(), a.keys, a.mirror ? ", with mirrors" : "");
  for (int i = 0; i < std::min(a.limit, s.size()); ++i)
    std::printf("\n[%s key %d frame %d%s]\n%s\n", clips[s.clip[i]].name.c_str(), s.key[i], s.frame[i],
                s.mirrored[i] ? " mirrored" : "", s.scripts[i].c_str());
  if (a.stats) print_stats(s);
  if (a.agreement > 0) {
    const pm::PostureModel m = pm::load_posture_model(a.posture);
    const pm::PostureScriptSet ref =
        pm::build_posture_script_set(t2m::cli::split_clips(d, t2m::data::Split::train, a.threads), a.keys, false);
    const auto r = pm::posture_agreement(m, s, ref, a.agreement, a.sample > 0 ? a.sample : 4, a.sampler, 7);
    std::printf("\nposture agreement (%s split, seed 7): %s\n", a.split.c_str(), r.to_json(a.sampler).dump().c_str());
  }
  if (!a.out.empty()) {
    std::ofstream f(a.out);
    if (!f) throw Error("data posescripts: cannot write --out " + a.out);
    for (int i = 0; i < s.size(); ++i)
      f << nlohmann::json{{"clip", clips[s.clip[i]].name}, {"key", s.key[i]}, {"frame", s.frame[i]},
                          {"mirrored", (bool)s.mirrored[i]}, {"script", s.scripts[i]}}
               .dump()
        << "\n";
    std::printf("wrote %s\n", a.out.c_str());
  }
}

void add(CLI::App& app) {
  auto* g = t2m::cli::command_group(app, "data", "Motion data set: unpack + manifest, statistics, BVH check");
  auto a = std::make_shared<Args>();
  auto* c = g->add_subcommand("posescripts", "PRO-Motion posture scripts of the key poses of one split");
  c->add_option("--split", a->split, "train, val or test (default test)");
  c->add_option("--limit", a->limit, "key poses to print (default 5)");
  c->add_option("--keys", a->keys, "key frames per clip (default 8)");
  c->add_flag("--mirror", a->mirror, "also the mirrored clips");
  c->add_flag("--stats", a->stats, "print how often every posecode category fires");
  c->add_option("--out", a->out, "write every item as JSON lines");
  c->add_option("--plan", a->plan, "instead: print the planner's key-frame scripts for this prompt");
  c->add_option("--sample", a->sample, "with --plan: sample N poses per key frame (posture diffuser)");
  c->add_option("--agreement", a->agreement, "score the posture diffuser on N scripts of the split");
  c->add_option("--sampler-steps", a->sampler.steps, "posture sampling steps (0 = all, DDPM; else DDIM)");
  c->add_option("--eta", a->sampler.eta, "DDIM stochasticity in [0, 1]");
  c->add_option("--guidance", a->sampler.guidance, "posture classifier-free guidance w");
  c->add_option("--posture", a->posture, "posture diffuser for --sample (default models/checkpoints/...)");
  c->add_option("--table", a->table, "planner table for --plan (default models/checkpoints/promotion_planner.json)");
  c->add_option("--data", a->data_dir, "Data directory (see data prepare)");
  c->add_option("--cache", a->cache_dir, "Cache directory (see data prepare)");
  c->add_option("--threads", a->threads, "threads (default: all)");
  c->callback([a] { run(*a); });
}

T2M_COMMAND(add);

}  // namespace
