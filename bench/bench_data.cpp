// bench_data.cpp — data set throughput: read + parse + canonical FK of every clip of the prepared data set
// (target: <= 10 s for the ~500 MB of BVH on 2 cores), parse alone, and FK alone on one in-memory clip.
// Needs `t2m data prepare` first (uses $T2M_CACHE or ~/.cache/t2m); otherwise the benchmarks report an error.
#include <benchmark/benchmark.h>
#include <omp.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "models/data/dataset.h"
#include "sim/bvh.h"
#include "sim/skeleton.h"

namespace {

const t2m::data::Manifest* manifest() {
  static t2m::data::Manifest m;
  static bool tried = false;
  if (!tried) {
    tried = true;
    const std::string p = t2m::data::default_cache_dir() + "/bandai/manifest.json";
    if (std::filesystem::exists(p)) m = t2m::data::load_manifest(p);
  }
  return m.clips.empty() ? nullptr : &m;
}

size_t total_bytes(const t2m::data::Manifest& m) {
  size_t b = 0;
  for (const auto& c : m.clips) b += std::filesystem::file_size(c.bvh_path);
  return b;
}

// Every clip: read file + parse + motion_from_bvh, OpenMP over clips (threads = range(0)).
void BM_ParseAndFkAllClips(benchmark::State& state) {
  const auto* m = manifest();
  if (!m) return state.SkipWithError("no manifest: run `t2m data prepare` first");
  const int threads = (int)state.range(0);
  const size_t bytes = total_bytes(*m);
  long frames = 0;
  for (auto _ : state) {
    frames = 0;
    const int n = (int)m->clips.size();
#pragma omp parallel for schedule(dynamic, 4) num_threads(threads) reduction(+ : frames)
    for (int i = 0; i < n; ++i) {
      t2m::sim::Motion mo = t2m::data::load_clip(m->clips[i]);
      frames += mo.frames;
    }
  }
  state.SetBytesProcessed((int64_t)(bytes * state.iterations()));
  state.counters["clips"] = (double)m->clips.size();
  state.counters["frames"] = (double)frames;
  state.counters["MB"] = bytes / 1e6;
}
BENCHMARK(BM_ParseAndFkAllClips)->Arg(1)->Arg(2)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

std::string longest_clip_text(std::string* name) {
  const auto* m = manifest();
  const t2m::data::ClipInfo* best = &m->clips[0];
  for (const auto& c : m->clips)
    if (c.frames > best->frames) best = &c;
  *name = best->bvh_path;
  std::ifstream f(best->bvh_path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// Parse only (text already in memory), the longest clip.
void BM_ParseLongestClip(benchmark::State& state) {
  if (!manifest()) return state.SkipWithError("no manifest: run `t2m data prepare` first");
  std::string name;
  const std::string text = longest_clip_text(&name);
  for (auto _ : state) benchmark::DoNotOptimize(t2m::sim::parse_bvh(text, name));
  state.SetBytesProcessed((int64_t)(text.size() * state.iterations()));
}
BENCHMARK(BM_ParseLongestClip)->Unit(benchmark::kMillisecond);

// BVH -> canonical Motion (Euler -> quaternions + FK) only, the longest clip.
void BM_MotionFromBvhLongestClip(benchmark::State& state) {
  if (!manifest()) return state.SkipWithError("no manifest: run `t2m data prepare` first");
  std::string name;
  const t2m::sim::BvhMotion b = t2m::sim::parse_bvh(longest_clip_text(&name), name);
  for (auto _ : state) benchmark::DoNotOptimize(t2m::sim::motion_from_bvh(b));
  state.SetItemsProcessed((int64_t)b.frames * state.iterations());  // frames/s
}
BENCHMARK(BM_MotionFromBvhLongestClip)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
