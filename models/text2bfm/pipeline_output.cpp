// pipeline_output.cpp — write_generation: the output directory of `t2m generate`, written into a temporary
// sibling directory and renamed into place at the end (pipeline.h).
#include <unistd.h>

#include <chrono>
#include <filesystem>

#include "models/text2bfm/pipeline.h"
#include "nn/checkpoint.h"
#include "sim/export.h"
#include "sim/render.h"
#include "tensor/parallel.h"

namespace t2m::text2bfm {

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Removes a temporary directory unless released (every error path of write_generation).
struct TempDir {
  fs::path path;
  bool keep = false;
  ~TempDir() {
    if (!keep && !path.empty()) {
      std::error_code ec;
      fs::remove_all(path, ec);
    }
  }
};

json timing_json(const StageTimes& t) {
  return {{"text", t.text},       {"sample", t.sample},         {"decode", t.decode},
          {"rollout", t.rollout}, {"export", t.exporting},      {"render", t.render},
          {"total", t.text + t.sample + t.decode + t.rollout + t.exporting + t.render}};
}

// ".NAME<tag>PID": a hidden sibling of the output directory.
std::string hidden_name(const fs::path& target, const char* tag) {
  std::string s(1, '.');
  s.append(target.filename().string()).append(tag).append(std::to_string(::getpid()));
  return s;
}

}  // namespace

json write_generation(Generation& g, const Text2BfmModels& m, const std::string& dir, const WriteOptions& w) {
  if (dir.empty()) throw Error("generate: --out is empty");
  const fs::path out = fs::absolute(fs::path(dir)).lexically_normal();
  const fs::path target = out.has_filename() ? out : out.parent_path();
  std::error_code ec;
  if (fs::exists(target, ec) && !w.overwrite && !(fs::is_directory(target) && fs::is_empty(target, ec)))
    throw Error("generate: output directory " + target.string() + " exists and is not empty (use --overwrite)");
  const fs::path parent = target.parent_path();
  if (!fs::is_directory(parent, ec))
    throw Error("generate: cannot write " + target.string() + ": parent directory " + parent.string() +
                " does not exist");
  TempDir tmp;
  tmp.path = parent / hidden_name(target, ".tmp.");
  fs::remove_all(tmp.path, ec);
  if (!fs::create_directory(tmp.path, ec) || ec)
    throw Error("generate: cannot write into " + parent.string() + ": " +
                (ec ? ec.message() : std::string("cannot create a directory")));

  const auto& h = *m.humanoid;
  auto t0 = std::chrono::steady_clock::now();
  sim::export_bvh_file(h, g.traj, (tmp.path / "motion.bvh").string());
  {
    nn::Checkpoint ck;
    const int64_t F = g.traj.frames;
    ck.meta = {{"format", "t2m-states-1"}, {"fps", g.traj.fps}, {"prompt", g.prompt}, {"clauses", g.clauses}};
    ck.put("obs", Tensor::from_vector(g.obs, {F, (int64_t)g.obs.size() / F}));
    ck.put("qpos", Tensor::from_vector(g.traj.qpos, {F, g.traj.nq}));
    ck.put("qvel", Tensor::from_vector(g.traj.qvel, {F, g.traj.nv}));
    ck.put("z", g.z);
    ck.save((tmp.path / "states.bin").string());
  }
  g.times.exporting = seconds_since(t0);
  if (w.render) {
    t0 = std::chrono::steady_clock::now();
    sim::RenderOptions ro;
    ro.width = w.render_width;
    ro.height = w.render_height;
    sim::render_trajectory(m.humanoid, g.traj, (tmp.path / "render.mp4").string(), "", ro);
    g.times.render = seconds_since(t0);
  }

  const double duration = double(g.traj.frames - 1) / g.traj.fps;
  json metrics = {
      {"prompt", g.prompt},
      {"clauses", g.clauses},
      {"options",
       {{"seed", g.opt.seed}, {"length_s", g.opt.length_s}, {"cfg", g.opt.cfg}, {"steps", g.opt.steps},
        {"compose", g.opt.compose}, {"overlap", g.opt.overlap}, {"render", w.render}}},
      {"duration_s", duration},
      {"frames", g.traj.frames},
      {"control_steps", g.traj.frames - 1},
      {"falls", g.falls},
      {"fell", g.falls > 0},
      {"first_fall_s", g.first_fall_s < 0 ? json(nullptr) : json(g.first_fall_s)},
      {"min_root_height_m", g.min_root_height},
      {"fall_rule", "root (hips) below 0.5 m"},
      {"timing_s", timing_json(g.times)},
      {"cpu_s", {{"text", g.cpu.text}, {"sample", g.cpu.sample}, {"decode", g.cpu.decode}, {"rollout", g.cpu.rollout}}},
      {"threads", get_num_threads()},
      {"warnings", m.warnings},
      {"checkpoints", {{"text", m.paths.text}, {"vbb", m.paths.vbb}, {"gen", m.paths.gen}, {"bfm", m.paths.bfm}}},
      {"files", w.render ? json{"motion.bvh", "render.mp4", "states.bin", "metrics.json"}
                         : json{"motion.bvh", "states.bin", "metrics.json"}}};
  nn::write_file_atomic((tmp.path / "metrics.json").string(), metrics.dump(1) + "\n");

  // Swap into place: an empty target is removed, an old one (overwrite) moved aside and deleted after.
  fs::path old;
  if (fs::exists(target, ec)) {
    if (fs::is_directory(target) && fs::is_empty(target, ec)) {
      fs::remove(target, ec);
    } else {
      old = parent / hidden_name(target, ".old.");
      fs::remove_all(old, ec);
      fs::rename(target, old, ec);
      if (ec) throw Error("generate: cannot replace " + target.string() + ": " + ec.message());
    }
  }
  fs::rename(tmp.path, target, ec);
  if (ec) {
    if (!old.empty()) fs::rename(old, target, ec);
    throw Error("generate: cannot move the outputs to " + target.string() + ": " + ec.message());
  }
  tmp.keep = true;
  if (!old.empty()) fs::remove_all(old, ec);
  return metrics;
}

}  // namespace t2m::text2bfm
