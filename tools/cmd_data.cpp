// cmd_data.cpp — `t2m data prepare|stats|check`: unpack the motion data set, summarise it, check one BVH file.
#include <chrono>
#include <cstdio>
#include <map>

#include "models/data/dataset.h"
#include "sim/bvh.h"
#include "sim/skeleton.h"
#include "tensor/tensor.h"
#include "tools/command.h"

namespace {

struct DataOptions {
  std::string data_dir, cache_dir, file;
  bool force = false;
};

std::string resolve_data(const DataOptions& o) {
  std::string d = o.data_dir.empty() ? t2m::data::default_data_dir() : o.data_dir;
  if (d.empty())
    throw t2m::Error("data: no data directory found (looked at $T2M_DATA and ../shared/data/bandai); pass --data DIR");
  return d;
}
std::string resolve_cache(const DataOptions& o) {
  return o.cache_dir.empty() ? t2m::data::default_cache_dir() : o.cache_dir;
}

void print_summary(const t2m::data::Manifest& m) {
  int per[2] = {0, 0};
  long frames = 0;
  for (const auto& c : m.clips) ++per[c.dataset - 1], frames += c.frames;
  std::printf("manifest: %s/manifest.json\n", m.root.c_str());
  std::printf("clips: %zu (dataset-1: %d, dataset-2: %d), frames: %ld, duration: %.2f h, skipped: %zu\n",
              m.clips.size(), per[0], per[1], frames, m.total_duration() / 3600.0, m.skipped.size());
  for (size_t i = 0; i < m.skipped.size() && i < 20; ++i) std::printf("  skipped %s\n", m.skipped[i].c_str());
  if (m.skipped.size() > 20) std::printf("  ... and %zu more\n", m.skipped.size() - 20);
}

void run_prepare(const DataOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  const auto m = t2m::data::prepare_dataset(resolve_data(o), resolve_cache(o), o.force);
  print_summary(m);
  std::printf("prepare took %.1f s\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
}

void run_stats(const DataOptions& o) {
  const auto m = t2m::data::prepare_dataset(resolve_data(o), resolve_cache(o), false);
  print_summary(m);
  for (int ds = 1; ds <= 2; ++ds) {
    // content x style table: "count/minutes" per cell, in label-id order.
    std::map<std::pair<int, int>, std::pair<int, double>> cell;
    for (const auto& c : m.clips)
      if (c.dataset == ds) {
        auto& e = cell[{c.content, c.style}];
        e.first += 1, e.second += c.duration / 60.0;
      }
    const auto& cl = m.content_labels[ds - 1];
    const auto& sl = m.style_labels[ds - 1];
    if (cell.empty() || cl.empty() || sl.empty()) continue;
    std::printf("\ndataset-%d: clips / minutes per content (rows) x style (columns)\n%-20s", ds, "");
    for (const auto& s : sl) std::printf(" %13.13s", s.c_str());
    std::printf(" %13s\n", "total");
    for (int c = 0; c < (int)cl.size(); ++c) {
      std::printf("%-20.20s", cl[c].c_str());
      int n = 0;
      double mins = 0;
      for (int s = 0; s < (int)sl.size(); ++s) {
        auto it = cell.find({c, s});
        if (it == cell.end()) {
          std::printf(" %13s", "-");
        } else {
          std::printf(" %5d/%7.2f", it->second.first, it->second.second);
          n += it->second.first, mins += it->second.second;
        }
      }
      std::printf(" %5d/%7.2f\n", n, mins);
    }
  }
}

void run_check(const DataOptions& o) {
  const t2m::sim::BvhMotion b = t2m::sim::read_bvh(o.file);
  std::printf("%s: %zu joints, %d channels, %d frames, %.3f fps, %.2f s\n", o.file.c_str(), b.joints.size(),
              b.total_channels(), b.frames, 1.0 / b.frame_time, b.frames * b.frame_time);
  std::string names;
  for (const auto& j : b.joints) names += (names.empty() ? "" : " ") + j.name;
  std::printf("joints: %s\n", names.c_str());
  const t2m::sim::Motion m = t2m::sim::motion_from_bvh(b);  // throws (exit 1) when not the canonical skeleton
  float lo = 1e30f, hi = -1e30f;
  for (int t = 0; t < m.frames; ++t) {
    const float z = m.pos[(size_t)t * t2m::sim::kNumJoints * 3 + 2];
    lo = std::min(lo, z), hi = std::max(hi, z);
  }
  std::printf("canonical skeleton: ok (21 joints); hips height %.3f..%.3f m\n", m.frames ? lo : 0.f,
              m.frames ? hi : 0.f);
}

void add_data(CLI::App& app) {
  auto* data = t2m::cli::command_group(app, "data", "Motion data set: unpack + manifest, statistics, BVH check");
  data->require_subcommand(1);
  auto opts = std::make_shared<DataOptions>();
  auto* prep = data->add_subcommand("prepare", "Unpack the .tar.zst archives into the cache and build the manifest");
  prep->add_option("--data", opts->data_dir, "Directory with dataset-{1,2}.tar.zst and cfg/ (default: $T2M_DATA "
                                              "or ../shared/data/bandai)");
  prep->add_option("--cache", opts->cache_dir, "Cache directory (default: $T2M_CACHE or ~/.cache/t2m)");
  prep->add_flag("--force", opts->force, "Rebuild the manifest even when it is up to date");
  prep->callback([opts] { run_prepare(*opts); });
  auto* stats = data->add_subcommand("stats", "Clip counts, total duration, content x style table");
  stats->add_option("--data", opts->data_dir, "Data directory (see prepare)");
  stats->add_option("--cache", opts->cache_dir, "Cache directory (see prepare)");
  stats->callback([opts] { run_stats(*opts); });
  auto* check = data->add_subcommand("check", "Parse one BVH file; print joints/frames/fps or the error (exit 1)");
  check->add_option("FILE", opts->file, "BVH file")->required();
  check->callback([opts] { run_check(*opts); });
}

T2M_COMMAND(add_data);

}  // namespace
