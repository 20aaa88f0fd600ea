// pipeline_output.cpp — write_generation: the output directory of `t2m generate`, written into a temporary
// sibling directory and renamed into place at the end (pipeline.h).
#include <chrono>

#include "models/io/output_dir.h"
#include "models/text2bfm/pipeline.h"
#include "nn/checkpoint.h"
#include "sim/export.h"
#include "sim/render.h"
#include "tensor/parallel.h"

namespace t2m::text2bfm {

namespace {

using json = nlohmann::json;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

json timing_json(const StageTimes& t) {
  return {{"text", t.text},       {"sample", t.sample},         {"decode", t.decode},
          {"rollout", t.rollout}, {"export", t.exporting},      {"render", t.render},
          {"total", t.text + t.sample + t.decode + t.rollout + t.exporting + t.render}};
}

}  // namespace

json write_generation(Generation& g, const Text2BfmModels& m, const std::string& dir, const WriteOptions& w) {
  io::OutputDir out(dir, w.overwrite, "generate");

  const auto& h = *m.humanoid;
  auto t0 = std::chrono::steady_clock::now();
  sim::export_bvh_file(h, g.traj, out.file("motion.bvh"));
  {
    nn::Checkpoint ck;
    const int64_t F = g.traj.frames;
    ck.meta = {{"format", "t2m-states-1"}, {"fps", g.traj.fps}, {"prompt", g.prompt}, {"clauses", g.clauses}};
    ck.put("obs", Tensor::from_vector(g.obs, {F, (int64_t)g.obs.size() / F}));
    ck.put("qpos", Tensor::from_vector(g.traj.qpos, {F, g.traj.nq}));
    ck.put("qvel", Tensor::from_vector(g.traj.qvel, {F, g.traj.nv}));
    ck.put("z", g.z);
    ck.save(out.file("states.bin"));
  }
  g.times.exporting = seconds_since(t0);
  if (w.render) {
    t0 = std::chrono::steady_clock::now();
    sim::RenderOptions ro;
    ro.width = w.render_width;
    ro.height = w.render_height;
    sim::render_trajectory(m.humanoid, g.traj, out.file("render.mp4"), "", ro);
    g.times.render = seconds_since(t0);
  }

  const double duration = double(g.traj.frames - 1) / g.traj.fps;
  json metrics = {
      {"prompt", g.prompt},
      {"clauses", g.clauses},
      {"options",
       {{"seed", g.opt.seed}, {"length_s", g.opt.length_s}, {"cfg", g.opt.cfg}, {"steps", g.opt.steps},
        {"compose", g.opt.compose}, {"overlap", g.opt.overlap}, {"candidates", g.opt.candidates},
        {"render", w.render}}},
      {"duration_s", duration},
      {"frames", g.traj.frames},
      {"control_steps", g.traj.frames - 1},
      {"falls", g.falls},
      {"fell", g.falls > 0},
      {"first_fall_s", g.first_fall_s < 0 ? json(nullptr) : json(g.first_fall_s)},
      {"min_root_height_m", g.min_root_height},
      {"candidate", g.candidate},
      {"candidate_seed", g.opt.seed + uint64_t(g.candidate)},
      {"candidate_upright_s", g.candidate_upright_s},
      {"fall_rule", "root (hips) below 0.5 m"},
      {"timing_s", timing_json(g.times)},
      {"cpu_s", {{"text", g.cpu.text}, {"sample", g.cpu.sample}, {"decode", g.cpu.decode}, {"rollout", g.cpu.rollout}}},
      {"threads", get_num_threads()},
      {"warnings", m.warnings},
      {"checkpoints", {{"text", m.paths.text}, {"vbb", m.paths.vbb}, {"gen", m.paths.gen}, {"bfm", m.paths.bfm}}},
      {"files", w.render ? json{"motion.bvh", "render.mp4", "states.bin", "metrics.json"}
                         : json{"motion.bvh", "states.bin", "metrics.json"}}};
  nn::write_file_atomic(out.file("metrics.json"), metrics.dump(1) + "\n");

  out.commit();
  return metrics;
}

}  // namespace t2m::text2bfm
