// cmd_train_variants.cpp — `t2m train <family> --variant V`: one leaf per family of the variant registry
// (train_variants.h), with the common flags; dispatches to the registered trainer.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <set>

#include "models/data/dataset.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"
#include "tools/command.h"
#include "tools/train_variants.h"

namespace t2m::cli {

std::vector<TrainVariant>& train_variants() {
  static std::vector<TrainVariant> variants;
  return variants;
}

std::string VariantTrainArgs::get(const std::string& key, const std::string& fallback) const {
  auto it = sets.find(key);
  return it == sets.end() ? fallback : it->second;
}

int64_t VariantTrainArgs::get_int(const std::string& key, int64_t fallback) const {
  auto it = sets.find(key);
  if (it == sets.end()) return fallback;
  char* end = nullptr;
  const long long v = std::strtoll(it->second.c_str(), &end, 10);
  if (it->second.empty() || *end != '\0')
    throw Error("train " + family + ": --set " + key + "=" + it->second + " is not an integer");
  return v;
}

double VariantTrainArgs::get_double(const std::string& key, double fallback) const {
  auto it = sets.find(key);
  if (it == sets.end()) return fallback;
  char* end = nullptr;
  const double v = std::strtod(it->second.c_str(), &end);
  if (it->second.empty() || *end != '\0')
    throw Error("train " + family + ": --set " + key + "=" + it->second + " is not a number");
  return v;
}

void VariantTrainArgs::check_keys(const std::vector<std::string>& known) const {
  for (const auto& [k, v] : sets) {
    bool ok = false;
    for (const auto& n : known) ok = ok || n == k;
    if (!ok) {
      std::string list;
      for (const auto& n : known) list += (list.empty() ? "" : ", ") + n;
      throw Error("train " + family + " --variant " + variant + ": unknown --set key '" + k + "' (known: " +
                  (list.empty() ? std::string("none") : list) + ")");
    }
  }
}

std::vector<data::MotionClip> VariantTrainArgs::split_clips(data::Split split) const {
  const std::string mp = manifest.empty() ? data::default_cache_dir() + "/bandai/manifest.json" : manifest;
  if (!std::filesystem::exists(mp))
    throw Error("train " + family + ": no manifest at " + mp + " (run `t2m data prepare`)");
  const auto m = data::load_manifest(mp);
  std::vector<std::string> names;
  for (const auto& c : m.clips) names.push_back(c.name);
  return data::load_split_clips(m, data::assign_splits(names), split, threads);
}

std::string VariantTrainArgs::command_line() const {
  std::string s = "t2m train " + family + " --variant " + variant + " --out " + out;
  if (steps) s += " --steps " + std::to_string(steps);
  if (batch) s += " --batch " + std::to_string(batch);
  if (lr > 0) s += " --lr " + std::to_string(lr);
  s += " --seed " + std::to_string(seed);
  for (const auto& [k, v] : sets) s += " --set " + k + "=" + v;
  return s;
}

}  // namespace t2m::cli

namespace {

using t2m::Error;
using t2m::cli::TrainVariant;
using t2m::cli::VariantTrainArgs;

struct FamilyArgs {
  VariantTrainArgs a;
  std::vector<std::string> sets;
  bool list = false;
};

void run_family(FamilyArgs& f) {
  const auto& all = t2m::cli::train_variants();
  std::string known;
  const TrainVariant* v = nullptr;
  for (const auto& t : all) {
    if (t.family != f.a.family) continue;
    known += (known.empty() ? "" : ", ") + t.variant;
    if (t.variant == f.a.variant) v = &t;
  }
  if (f.list) {
    for (const auto& t : all)
      if (t.family == f.a.family) std::printf("%-16s %s\n", t.variant.c_str(), t.description.c_str());
    return;
  }
  if (f.a.variant.empty()) throw Error("train " + f.a.family + ": give --variant (one of: " + known + ")");
  if (!v) throw Error("train " + f.a.family + ": unknown --variant '" + f.a.variant + "' (known: " + known + ")");
  VariantTrainArgs a = f.a;
  for (const auto& s : f.sets) {
    const size_t eq = s.find('=');
    if (eq == std::string::npos || eq == 0)
      throw Error("train " + a.family + ": --set expects KEY=VALUE, got '" + s + "'");
    a.sets[s.substr(0, eq)] = s.substr(eq + 1);
  }
  if (a.steps < 0 || a.batch < 0 || a.save_every < 0 || a.stop_at < 0 || a.lr < 0 || a.threads < 0)
    throw Error("train " + a.family + ": --steps, --batch, --save-every, --stop-at, --lr and --threads must be >= 0");
  if (a.threads > 0) t2m::set_num_threads(a.threads);
  if (a.out.empty()) a.out = t2m::data::default_cache_dir() + "/" + a.family + "-" + a.variant;
  if (a.manifest.empty()) a.manifest = t2m::data::default_cache_dir() + "/bandai/manifest.json";
  v->train(a);
}

void add_train_variants(CLI::App& app) {
  std::set<std::string> families;
  for (const auto& t : t2m::cli::train_variants()) families.insert(t.family);
  if (families.empty()) return;
  auto* grp = t2m::cli::command_group(app, "train", "train a model");
  for (const auto& fam : families) {
    auto f = std::make_shared<FamilyArgs>();
    f->a.family = fam;
    auto* c = grp->add_subcommand(fam, "train a " + fam + " model (--variant; --list shows them)");
    c->add_option("--variant", f->a.variant, "which model of the family");
    c->add_flag("--list", f->list, "print the variants and exit");
    c->add_option("--out", f->a.out, "run directory (default ~/.cache/t2m/<family>-<variant>)");
    c->add_option("--ship", f->a.ship, "also copy the final checkpoint here (models/checkpoints/...)");
    c->add_option("--checkpoints", f->a.checkpoints, "directory of the frozen inputs")->capture_default_str();
    c->add_option("--manifest", f->a.manifest, "data manifest (default ~/.cache/t2m/bandai/manifest.json)");
    c->add_option("--steps", f->a.steps, "optimizer steps (0 = the variant's default)");
    c->add_option("--batch", f->a.batch, "batch size (0 = default)");
    c->add_option("--save-every", f->a.save_every, "steps between resumable checkpoints (0 = default)");
    c->add_option("--stop-at", f->a.stop_at, "stop (resumably) after this many steps in total");
    c->add_option("--lr", f->a.lr, "peak learning rate (0 = default)");
    c->add_option("--seed", f->a.seed, "seed")->capture_default_str();
    c->add_option("--threads", f->a.threads, "threads (0 = default)");
    c->add_flag("--resume", f->a.resume, "continue from OUT's training state");
    c->add_option("--set", f->sets, "variant-specific hyper-parameter KEY=VALUE (repeatable)");
    c->callback([f] { run_family(*f); });
  }
}

}  // namespace

T2M_COMMAND(add_train_variants);
