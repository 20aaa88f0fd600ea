// eval_generation.h — generating the motions `t2m eval text2bfm` scores: one Text2BFM generation (pipeline.h,
// no render, no files) per evaluation prompt at the length of the real clip the prompt describes, plus S samples
// of a subset of prompts for MultiModality, converted to the evaluator's raw features.
//
// trajectory_features(h, traj, first): frames first .. frames-1 of a simulated qpos trajectory ->
//   sim::motion_from_qpos (the data skeleton, Z up) -> data::motion_to_features: [frames - first, 257] raw.
//   A generation records T + 1 states (s_0 = the standing start), so first = 1 gives T frames, the length of the
//   clip the prompt came from.
// generate_eval_motions(m, items, opt): items[i] = (caption, frames T_i). Item i is generated with
//   GenerateOptions opt.gen, length T_i / 30 s, the item's start state (if any), seed = sample_seed(opt.seed, i, 0);
//   the mm_prompts items i = floor(k * n / mm_prompts), k = 0..mm_prompts-1 (spread over the list) get opt.samples
//   samples each (sample s: seed sample_seed(opt.seed, i, s); sample 0 is the main one). Output entries
//   (motion_dir.h), one per generated motion, in item order: "iiii.npy" for items without extra samples,
//   "iiii_ss.npy" with prompt = k for the MultiModality prompts; so main_set() is every item exactly once.
//   Generations run in parallel over items with `jobs` OpenMP threads (each generation single-threaded inside);
//   every output bit depends only on the seeds, not on jobs (each motion is computed by one thread from its own
//   Generator). progress(done, total) is called after each motion (from any thread, serialised).
//   Stats: wall and process CPU seconds (all threads) of the whole call, per-stage wall seconds summed over
//   generations, control steps, generations that fell and their mean first-fall time; item_fell[i]: whether item
//   i's main generation (sample 0) fell.
// Errors (t2m::Error "eval text2bfm: ..."): no items, an item with frames < 1 or an empty caption, samples < 2
//   with mm_prompts > 0, mm_prompts > items, jobs < 1; pipeline errors pass through (the first one is rethrown).
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "models/eval/motion_dir.h"
#include "models/text2bfm/pipeline.h"

namespace t2m::text2bfm {

std::vector<float> trajectory_features(const sim::Humanoid& h, const sim::QposTrajectory& traj, int first = 1);

struct EvalItem {
  std::string caption;
  int64_t frames = 0;  // T, control steps (30 Hz)
  std::vector<double> start_qpos = {}, start_qvel = {};  // the rollouts' first state; empty: the standing start
};

struct EvalGenOptions {
  GenerateOptions gen;     // cfg, steps, compose, overlap (seed and length are set per item)
  uint64_t seed = 0;
  int64_t mm_prompts = 32;  // prompts with extra samples for MultiModality (0: none)
  int64_t samples = 10;     // S samples per MultiModality prompt
  int jobs = 1;             // OpenMP threads over items
};

struct EvalGenStats {
  double wall_s = 0, cpu_s = 0;
  double text_s = 0, sample_s = 0, decode_s = 0, rollout_s = 0;  // per-stage wall seconds summed over generations
  int64_t generations = 0, control_steps = 0, fell = 0;
  double mean_first_fall_s = 0;  // over generations that fell
};

struct EvalGenResult {
  std::vector<eval::MotionEntry> entries;
  EvalGenStats stats;
  std::vector<bool> item_fell;  // per item: its main generation (sample 0) fell
};

// Seed of sample s of item i: a splitmix64 mix of (seed, i, s).
uint64_t sample_seed(uint64_t seed, int64_t item, int64_t sample);

EvalGenResult generate_eval_motions(Text2BfmModels& m, const std::vector<EvalItem>& items,
                                    const EvalGenOptions& opt,
                                    const std::function<void(int64_t, int64_t)>& progress = nullptr);

}  // namespace t2m::text2bfm
