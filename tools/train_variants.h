// train_variants.h — `t2m train <family> --variant <variant>`: one command per model family (casim, promotion, ...)
// whose variants register themselves from their own tools/train_*.cpp files:
//
//   void train_diff_cls(const t2m::cli::VariantTrainArgs& a) { ... }
//   T2M_TRAIN_VARIANT("casim", "diff-cls", "MDM diffusion conditioned on the sentence embedding", train_diff_cls);
//
// Common flags (every family): --variant (required), --out DIR (default ~/.cache/t2m/<family>-<variant>),
// --ship PATH, --checkpoints DIR (frozen inputs, default models/checkpoints), --manifest (default
// ~/.cache/t2m/bandai/manifest.json), --steps, --batch, --save-every, --stop-at (0 = the variant's default),
// --lr (0 = default), --seed, --threads (0 = default), --resume, --set KEY=VALUE (repeatable; variant-specific
// hyper-parameters, read with VariantTrainArgs::get / get_int / get_double, which reject unknown keys when
// `check_keys` is called). `t2m train <family> --list` prints the variants.
#pragma once
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "models/data/loader.h"
#include "models/data/splits.h"

namespace t2m::cli {

struct VariantTrainArgs {
  std::string family, variant;
  std::string out, ship, checkpoints = "models/checkpoints", manifest;
  int64_t steps = 0, batch = 0, save_every = 0, stop_at = 0;
  double lr = 0;
  uint64_t seed = 0;
  int threads = 0;
  bool resume = false;
  std::map<std::string, std::string> sets;  // --set KEY=VALUE

  // Value of --set KEY, or `fallback` when not given. get_int / get_double throw t2m::Error on a malformed number.
  std::string get(const std::string& key, const std::string& fallback) const;
  int64_t get_int(const std::string& key, int64_t fallback) const;
  double get_double(const std::string& key, double fallback) const;
  // Throws t2m::Error naming the first --set key that is not in `known`.
  void check_keys(const std::vector<std::string>& known) const;
  // The clips of one split (the --manifest data, splits of models/data/splits.h, --threads for loading); a missing
  // manifest is an error that names it and `t2m data prepare`.
  std::vector<data::MotionClip> split_clips(data::Split split) const;
  // The command that reproduces this run: "t2m train FAMILY --variant V --out OUT [--steps N] [--batch B] [--lr X]
  // --seed S [--set K=V]..." (stored in the shipped checkpoints' metadata).
  std::string command_line() const;
};

// Copies the common flags onto a trainer config with fields steps, batch, lr, save_every, stop_at and seed: flags
// left at 0 keep the config's defaults (stop_at and seed are always copied).
template <class TrainConfig>
void apply_common_flags(const VariantTrainArgs& a, TrainConfig& tc) {
  if (a.steps) tc.steps = a.steps;
  if (a.batch) tc.batch = a.batch;
  if (a.lr > 0) tc.lr = a.lr;
  if (a.save_every) tc.save_every = a.save_every;
  tc.stop_at = a.stop_at;
  tc.seed = a.seed;
}

using VariantTrainer = void (*)(const VariantTrainArgs&);

struct TrainVariant {
  std::string family, variant, description;
  VariantTrainer train = nullptr;
};

std::vector<TrainVariant>& train_variants();

struct TrainVariantRegistrar {
  TrainVariantRegistrar(const char* family, const char* variant, const char* description, VariantTrainer fn) {
    train_variants().push_back({family, variant, description, fn});
  }
};

}  // namespace t2m::cli

#define T2M_TRAIN_VARIANT_CAT2(a, b) a##b
#define T2M_TRAIN_VARIANT_CAT(a, b) T2M_TRAIN_VARIANT_CAT2(a, b)
#define T2M_TRAIN_VARIANT(family, variant, description, fn) \
  static ::t2m::cli::TrainVariantRegistrar T2M_TRAIN_VARIANT_CAT(t2m_train_variant_reg_, __LINE__)(family, variant, description, fn)
