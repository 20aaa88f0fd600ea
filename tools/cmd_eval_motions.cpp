// cmd_eval_motions.cpp — `t2m eval motions [DIR] [--real]`: the text-to-motion metrics (R-precision top-1/2/3 in
// batches of 32 with the caption-shuffled control, FID, MM-Dist, Diversity, MultiModality; 20 seeded runs, mean and
// 95% CI) with the metric evaluator (models/checkpoints/evaluator.t2mckpt by default) for a directory of motions
// (format: models/eval/motion_dir.h, docs/TEXT.md) or, with --real, for the real clips of a split against their
// own captions (the "real motion" ceiling row). FID reference: the real clips of the split (--reference real),
// none, or another motions directory. Writes a JSON report atomically and prints a table.
#include <cstdio>
#include <filesystem>
#include <string>

#include "models/data/captions.h"
#include "models/eval/evaluate_motions.h"
#include "models/eval/evaluator.h"
#include "models/eval/motion_dir.h"
#include "nn/checkpoint.h"
#include "tensor/parallel.h"
#include "tools/command.h"
#include "tools/text_data.h"

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using t2m::Error;

constexpr uint64_t kRealCaptionSeed = 7;  // captions of real clips: make_caption(labels, 7, 0), as train summaries

struct EvalArgs {
  t2m::cli::TextDataOptions data;
  std::string dir, evaluator = "models/checkpoints/evaluator.t2mckpt", reference = "real", split = "test", out;
  std::string reference_split;  // "" = split
  bool real = false;
  t2m::eval::EvalProtocol protocol;
};

void run_eval(const EvalArgs& a) {
  if (a.real == !a.dir.empty()) throw Error("eval motions: give either a motions directory or --real (not both)");
  if (a.protocol.runs < 1) throw Error("eval motions: --runs must be >= 1");
  if (a.data.threads > 0) t2m::set_num_threads(a.data.threads);
  const t2m::data::Split split = t2m::data::split_from_name(a.split);
  if (!fs::exists(a.evaluator))
    throw Error("eval motions: evaluator checkpoint '" + a.evaluator +
                "' not found (run from the repository root, pass --evaluator, or train one: t2m train evaluator)");
  const auto ev = t2m::eval::load_evaluator(a.evaluator);

  // Motions to score.
  t2m::eval::MotionDir md;
  std::vector<t2m::data::MotionClip> real_clips;
  t2m::cli::TextData td;
  const std::string ref_split_name = a.reference_split.empty() ? a.split : a.reference_split;
  const t2m::data::Split ref_split = t2m::data::split_from_name(ref_split_name);
  std::vector<t2m::data::MotionClip> ref_clips;
  if (a.real || a.reference == "real") {
    td = t2m::cli::load_text_data(a.data);
    if (a.real) real_clips = t2m::cli::split_clips(td, split, a.data.threads);
    if (a.real && real_clips.empty()) throw Error("eval motions: the " + a.split + " split has no clips");
    if (a.reference == "real") {
      ref_clips = ref_split == split && a.real ? real_clips : t2m::cli::split_clips(td, ref_split, a.data.threads);
      if (ref_clips.empty()) throw Error("eval motions: the " + ref_split_name + " split has no clips");
    }
  }
  t2m::eval::MotionSet set;
  std::string what;
  if (a.real) {
    for (const auto& c : real_clips) {
      set.captions.push_back(t2m::data::make_caption(c.content, c.style, kRealCaptionSeed, 0).text);
      set.motions.push_back(&c.features);
    }
    what = "real motions of the " + a.split + " split (Bandai-Namco, CC BY-NC 4.0) against their own captions";
  } else {
    md = t2m::eval::load_motion_dir(a.dir);
    set = t2m::eval::motion_set_of(md);
    what = "motions of " + a.dir;
  }

  // FID reference.
  t2m::Tensor reference;
  std::string ref_what = "none";
  t2m::eval::MotionDir ref_dir;
  if (a.reference == "real") {
    std::vector<const std::vector<float>*> r;
    for (const auto& c : ref_clips) r.push_back(&c.features);
    reference = t2m::text::embed_motions(ev, r);
    ref_what = "real motions of the " + ref_split_name + " split";
  } else if (a.reference != "none") {
    ref_dir = t2m::eval::load_motion_dir(a.reference);
    std::vector<const std::vector<float>*> r;
    for (const auto& e : ref_dir.entries) r.push_back(&e.features);
    reference = t2m::text::embed_motions(ev, r);
    ref_what = "motions of " + a.reference;
  }

  const auto rep = t2m::eval::evaluate_motions(ev, set, reference, a.protocol);
  json j = rep.to_json();
  j["motions"] = what;
  j["count"] = set.motions.size();
  j["multimodality_prompts"] = set.groups.size();
  j["fid_reference"] = ref_what;
  j["evaluator"] = a.evaluator;
  j["note"] =
      "embeddings are unit vectors of the GRU evaluator trained on the Bandai train split: MM-Dist, "
      "Diversity and FID are on that scale, not comparable to HumanML3D numbers; chance R-precision "
      "top-k = k/32";
  std::string out = a.out;
  if (out.empty())
    out = a.real ? t2m::cli::default_output_dir("eval") + "/real_" + a.split + ".json" : a.dir + "/eval.json";
  if (!fs::path(out).parent_path().empty()) fs::create_directories(fs::path(out).parent_path());
  t2m::nn::write_file_atomic(out, j.dump(1) + "\n");

  std::printf("%s: %zu motions, %d runs (seed %llu)\n", what.c_str(), set.motions.size(), a.protocol.runs,
              (unsigned long long)a.protocol.seed);
  std::fputs(t2m::eval::report_lines(rep).c_str(), stdout);
  std::printf("report: %s\n", out.c_str());
}

void add_eval_motions(CLI::App& app) {
  auto* g = t2m::cli::command_group(app, "eval", "evaluate models and motions");
  auto a = std::make_shared<EvalArgs>();
  auto* c = g->add_subcommand("motions", "text-to-motion metrics of a motions directory (or --real: the real row)");
  c->add_option("dir", a->dir, "directory with motions.json (see docs/TEXT.md)");
  c->add_flag("--real", a->real, "score the split's real motions against their own captions (the ceiling row)");
  c->add_option("--split", a->split, "split of the real motions (--real, --reference real)")->capture_default_str();
  c->add_option("--evaluator", a->evaluator, "metric evaluator checkpoint")->capture_default_str();
  c->add_option("--reference", a->reference, "FID reference: real | none | a motions directory")->capture_default_str();
  c->add_option("--reference-split", a->reference_split, "split of the FID reference (default: --split)");
  c->add_option("--runs", a->protocol.runs, "seeded repetitions (mean and 95% CI)")->capture_default_str();
  c->add_option("--seed", a->protocol.seed, "seed of the runs")->capture_default_str();
  c->add_option("--diversity-pairs", a->protocol.diversity_pairs, "pairs for Diversity")->capture_default_str();
  c->add_option("--mm-pairs", a->protocol.mm_pairs, "pairs per prompt for MultiModality")->capture_default_str();
  c->add_option("--out", a->out, "report path (default DIR/eval.json, or ~/.cache/t2m/eval/real_SPLIT.json)");
  c->add_option("--data", a->data.data_dir, "motion data directory");
  c->add_option("--cache", a->data.cache_dir, "cache directory");
  c->add_option("--threads", a->data.threads, "threads (0 = default)");
  c->callback([a] { run_eval(*a); });
}

}  // namespace

T2M_COMMAND(add_eval_motions);
