// cmd_sim.cpp — the simulation subcommands of `t2m`:
//   t2m retarget  [clip selection] [--out J]    retarget + kinematic replay, joint-position error per clip
//   t2m track-pd  [clip selection] [--out J]    PD tracking baseline: success, MPJPE, root drift, fall rate
//   t2m export    --bvh IN --out OUT.bvh [--mode pd|replay]   simulated (or replayed) motion -> BVH
//   t2m render    --bvh IN --out OUT.mp4 [--frames-dir D] [--mode replay|pd]   offscreen video / PNG frames
//   (export and render also take --qpos STATES.json, a state sequence, instead of --bvh)
// Clip selection: --bvh FILE (repeatable) or every *.bvh under --clips DIR (default $T2M_CACHE/bandai, else
// ~/.cache/t2m/bandai), filtered by --split (ignored for explicit --bvh files) (all | train | val | test: models/data/splits; take0: takes ending
// in 0) and --max-clips. Clips run in parallel (OpenMP, --threads). Every run prints a summary and, with --out,
// writes a JSON summary with per-clip numbers.


#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "models/bfm/planner_demos.h"
#include "models/bfm/policy_checkpoint.h"
#include "models/data/dataset.h"
#include "models/data/splits.h"
#include "sim/balance_tracker.h"
#include "sim/samcon.h"
#include "sim/ctrl_file.h"
#include "sim/samcon_mpc.h"
#include "sim/bvh.h"
#include "sim/env.h"
#include "sim/export.h"
#include "sim/pd_tracker.h"
#include "sim/render.h"
#include "sim/retarget.h"
#include "sim/skeleton.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"
#include "tools/command.h"

namespace {

using t2m::Error;
using json = nlohmann::json;
namespace fs = std::filesystem;
namespace sim = t2m::sim;

struct ClipArgs {
  std::vector<std::string> bvh;
  std::string clips_dir;
  std::string split = "all";
  int max_clips = 0;
  std::vector<std::string> content;  // content labels kept (empty = all)
  int every = 1;                     // every k-th clip of the selection
  int every_from = 0;                // ... starting at this index (0 <= every_from < every)
  int threads = 0;
  std::string out;
};

void add_clip_options(CLI::App* c, ClipArgs& a, const char* default_split) {
  a.split = default_split;
  c->add_option("--bvh", a.bvh, "BVH file(s) to use instead of a clip directory");
  c->add_option("--clips", a.clips_dir, "directory searched recursively for *.bvh (default: the t2m cache)");
  c->add_option("--split", a.split, "all | train | val | test | take0")->capture_default_str();
  c->add_option("--content", a.content, "keep only clips of these content labels (comma-separated, e.g. walk,run)")
      ->delimiter(',');
  c->add_option("--every", a.every, "keep every k-th of the selected clips (by name, from the first)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  c->add_option("--every-from", a.every_from,
                "with --every K: start at the J-th of the selected clips (0 <= J < K; --every 12 --every-from 6 takes "
                "the clips between those of --every 12)")
      ->capture_default_str();
  c->add_option("--max-clips", a.max_clips, "use at most N clips (0 = all), after sorting by name");
  c->add_option("--threads", a.threads, "OpenMP threads (0 = default)");
  c->add_option("--out", a.out, "write a JSON summary here");
}

std::string default_clips_dir() {
  if (const char* c = std::getenv("T2M_CACHE")) return std::string(c) + "/bandai";
  const char* home = std::getenv("HOME");
  return std::string(home ? home : ".") + "/.cache/t2m/bandai";
}

// name (file stem) -> path, selected and sorted.
std::vector<std::pair<std::string, std::string>> select_clips(const ClipArgs& a) {
  std::vector<std::pair<std::string, std::string>> all;
  if (!a.bvh.empty()) {
    for (const auto& p : a.bvh) {
      if (!fs::is_regular_file(p)) throw Error("no such BVH file '" + p + "'");
      all.emplace_back(fs::path(p).stem().string(), p);
    }
  } else {
    const std::string dir = a.clips_dir.empty() ? default_clips_dir() : a.clips_dir;
    if (!fs::is_directory(dir))
      throw Error("clip directory '" + dir + "' does not exist (unpack the data with `t2m data prepare`, or pass "
                  "--clips DIR / --bvh FILE)");
    for (const auto& e : fs::recursive_directory_iterator(dir))
      if (e.is_regular_file() && e.path().extension() == ".bvh") all.emplace_back(e.path().stem().string(), e.path());
  }
  std::sort(all.begin(), all.end());
  std::vector<std::pair<std::string, std::string>> sel;
  if (a.split == "all" || !a.bvh.empty()) {  // explicit --bvh files are used as given
    sel = all;
  } else if (a.split == "take0") {
    for (auto& c : all)
      if (!c.first.empty() && c.first.back() == '0') sel.push_back(c);
  } else {
    const t2m::data::Split want = t2m::data::split_from_name(a.split);
    std::vector<std::string> names;
    for (auto& c : all) names.push_back(c.first);
    const auto splits = t2m::data::assign_splits(names);
    for (auto& c : all)
      if (splits.at(c.first) == want) sel.push_back(c);
  }
  if (!a.content.empty()) {  // content labels of the names (dataset-N_<content>_<style>_<take>)
    std::vector<std::pair<std::string, std::string>> kept;
    for (auto& c : sel) {
      const std::string content = t2m::data::clip_content(c.first);
      if (!content.empty() && std::find(a.content.begin(), a.content.end(), content) != a.content.end())
        kept.push_back(c);
    }
    sel = kept;
  }
  if (a.every_from < 0 || a.every_from >= a.every)
    throw Error("--every-from " + std::to_string(a.every_from) + ": need 0 <= J < --every (" +
                std::to_string(a.every) + ")");
  if (a.every > 1) {
    std::vector<std::pair<std::string, std::string>> kept;
    for (size_t i = (size_t)a.every_from; i < sel.size(); i += (size_t)a.every) kept.push_back(sel[i]);
    sel = kept;
  }
  if (a.max_clips > 0 && (int)sel.size() > a.max_clips) sel.resize(a.max_clips);
  if (sel.empty()) throw Error("no clips selected (split '" + a.split + "')");
  return sel;
}

struct Progress {
  int total;
  int done = 0;
  std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
  double last = -1;
  void tick() {
    ++done;
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (done < total && s - last < 0.5) return;
    last = s;
    const double rate = done / std::max(s, 1e-9);
    std::fprintf(stderr, "\r[%d/%d] %.1f clips/s, ETA %.0f s   ", done, total, rate, (total - done) / rate);
    if (done == total) std::fprintf(stderr, "\n");
  }
};

void write_json(const std::string& path, const json& j) {
  if (path.empty()) return;
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp);
    if (!f) throw Error("cannot write '" + path + "'");
    f << j.dump(1) << "\n";
  }
  fs::rename(tmp, path);
  std::printf("wrote %s\n", path.c_str());
}

sim::Motion load_motion(const std::string& path) { return sim::motion_from_bvh(sim::read_bvh(path)); }

// ---- t2m retarget ----
void run_retarget(const ClipArgs& a) {
  const auto clips = select_clips(a);
  if (a.threads > 0) t2m::set_num_threads(a.threads);
  auto h = sim::Humanoid::create();
  const int N = (int)clips.size();
  std::vector<json> rows(N);
  std::vector<double> mean(N, -1), mx(N, 0), frames(N, 0);
  Progress prog{N};
#pragma omp parallel for schedule(dynamic)
  for (int i = 0; i < N; ++i) {
    json row = {{"name", clips[i].first}};
    try {
      const sim::Motion mo = load_motion(clips[i].second);
      const sim::QposTrajectory q = sim::retarget(*h, mo);
      const sim::ReplayError e = sim::replay_error(*h, q, mo);
      mean[i] = e.mean_m, mx[i] = e.max_m, frames[i] = mo.frames;
      row.update({{"frames", mo.frames}, {"mean_error_m", e.mean_m}, {"max_error_m", e.max_m},
                  {"clamped_hinge_values", q.clamped}, {"floor_shift_m", q.floor_shift}});
    } catch (const std::exception& ex) {
      row["error"] = ex.what();
    }
    rows[i] = row;
#pragma omp critical
    prog.tick();
  }
  double sum = 0, wsum = 0, fsum = 0, worst = 0;
  int ok = 0, over2 = 0;
  for (int i = 0; i < N; ++i)
    if (mean[i] >= 0) {
      ++ok, sum += mean[i], wsum += mean[i] * frames[i], fsum += frames[i], worst = std::max(worst, mx[i]);
      over2 += mean[i] > 0.02;
    }
  json s = {{"clips", N},
            {"clips_ok", ok},
            {"mean_of_clip_means_m", ok ? sum / ok : 0.0},
            {"frame_weighted_mean_m", fsum > 0 ? wsum / fsum : 0.0},
            {"worst_joint_error_m", worst},
            {"clips_over_2cm_mean", over2}};
  std::printf("retarget: %d/%d clips, mean joint error %.4f mm (frame-weighted %.4f mm), worst single joint %.1f mm, "
              "%d clips above 2 cm mean\n",
              ok, N, 1e3 * s["mean_of_clip_means_m"].get<double>(), 1e3 * s["frame_weighted_mean_m"].get<double>(),
              1e3 * worst, over2);
  write_json(a.out, {{"command", "retarget"}, {"split", a.split}, {"summary", s}, {"clips", rows}});
}

// ---- t2m track-pd ----
struct PdArgs {
  ClipArgs clips;
  double assist = 0;
  double gain_scale = 1;
  bool no_ff = false;
  bool balance = false;
  sim::BalanceOptions bo;
  bool samcon = false;
  sim::SamconOptions so;
  bool mpc = false;  // --samcon-mpc: the closed-loop search (window, sigma and seed from so)
  sim::SamconMpcOptions mo;
  bool mpc_lower_body = false;  // --mpc-lower-body: offsets on the trunk and legs only (mo.hinges)
  std::string mpc_student;      // --mpc-student POLICY: DAgger, the policy drives (mo.driver_share of the windows)
  std::string export_dir;
  bool resume = false;  // skip clips whose NAME.ctrl.json is in export_dir (a search's finished clip)
};

void run_track_pd(const PdArgs& a) {
  const auto clips = select_clips(a.clips);
  if (a.clips.threads > 0) t2m::set_num_threads(a.clips.threads);
  sim::HumanoidOptions ho;
  ho.gain_scale = a.gain_scale;
  auto h = sim::Humanoid::create(ho);
  std::unique_ptr<t2m::bfm::FbAgent> student;  // --mpc-student (checked before anything is written)
  if (!a.mpc_student.empty()) student = t2m::bfm::load_policy(a.mpc_student);
  if (!a.export_dir.empty()) fs::create_directories(a.export_dir);
  const int N = (int)clips.size();
  std::vector<json> rows(N);
  std::vector<sim::PdResult> res(N);
  std::vector<char> ok(N, 0);
  sim::PdOptions po;
  po.velocity_feedforward = !a.no_ff;
  Progress prog{N};
  const auto t0 = std::chrono::steady_clock::now();
  // --samcon / --samcon-mpc search each clip with all threads (sim/samcon*.h); the other controllers run one clip
  // per thread.
  const bool search = a.samcon || a.mpc;
#pragma omp parallel for schedule(dynamic) if (!search)
  for (int i = 0; i < N; ++i) {
    json row = {{"name", clips[i].first}};
    const std::string ctrl_path = a.export_dir + "/" + clips[i].first + ".ctrl.json";
    if (a.resume && fs::exists(ctrl_path)) {  // finished by an earlier invocation: its seed was seed + i too
      row["skipped"] = "exported earlier";
      rows[i] = row;
#pragma omp critical
      prog.tick();
      continue;
    }
    try {
      const sim::QposTrajectory ref = sim::retarget(*h, load_motion(clips[i].second));
      // The searches' actuator targets per control step (a demonstration) -> NAME.ctrl.json, written after the
      // clip's other files: its presence marks a finished clip (--resume).
      sim::CtrlSequence demo;
      auto export_ctrl = [&](int searched, const std::vector<double>& ctrl, const std::vector<double>& offset) {
        row["frames_searched"] = searched;
        demo = sim::CtrlSequence{ref.fps, h->model()->nu, searched, ctrl, offset};
      };
      if (a.samcon) {
        sim::SamconOptions so = a.so;
        so.balance = a.bo;
        so.seed = a.so.seed + (uint64_t)i;  // per clip
        sim::SamconResult sr = sim::track_samcon(h, ref, so, po);
        export_ctrl(sr.frames_searched, sr.ctrl, sr.offset);
        res[i] = std::move(sr.track);
      } else if (a.mpc) {
        sim::SamconMpcOptions mo = a.mo;
        mo.window = a.so.window, mo.sigma = a.so.sigma, mo.balance = a.bo;
        if (a.mpc_lower_body) mo.hinges = sim::lower_body_actuators(*h);
        mo.seed = a.so.seed + (uint64_t)i;  // per clip
        const sim::BodyDriver driver = student ? t2m::bfm::policy_driver(*student, h, ref) : sim::BodyDriver{};
        sim::SamconMpcResult mr = sim::track_samcon_mpc(h, ref, mo, po, driver);
        export_ctrl(mr.frames_planned, mr.ctrl, mr.offset);
        res[i] = std::move(mr.track);
      } else {
        sim::Env env(h, sim::EnvOptions{.substeps = sim::kSubsteps, .assist_force = a.assist});
        sim::BalanceOptions bo = a.bo;
        bo.noise_seed = (uint64_t)i;  // per clip: independent of the thread schedule
        res[i] = a.balance ? sim::track_balance(env, ref, bo, po) : sim::track_pd(env, ref, po);
      }
      res[i].assist_force = a.assist;
      const auto& r = res[i];
      ok[i] = 1;
      row.update({{"frames", r.frames}, {"success", r.success}, {"fell", r.fell}, {"mpjpe_m", r.mpjpe_m},
                  {"root_drift_m", r.root_drift_m}, {"frames_ok", r.frames_ok}, {"max_error_m", r.max_error_m}});
      if (!a.export_dir.empty()) {
        sim::export_bvh_file(*h, r.simulated, a.export_dir + "/" + clips[i].first + ".bvh");
        sim::save_trajectory_json(r.simulated, a.export_dir + "/" + clips[i].first + ".qpos.json");
        if (search) sim::save_ctrl_json(demo, ctrl_path);
      }
      res[i].simulated = {};  // free the trajectory
    } catch (const std::exception& ex) {
      row["error"] = ex.what();
    }
    rows[i] = row;
#pragma omp critical
    prog.tick();
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  int n = 0, succ = 0, fell = 0, skipped = 0;
  double mpjpe = 0, drift = 0, frac_ok = 0, frames = 0;
  for (const json& r : rows) skipped += r.contains("skipped");
  for (int i = 0; i < N; ++i)
    if (ok[i]) {
      ++n, succ += res[i].success, fell += res[i].fell, mpjpe += res[i].mpjpe_m, drift += res[i].root_drift_m;
      frac_ok += double(res[i].frames_ok) / res[i].frames, frames += res[i].frames;
    }
  const double dn = std::max(n, 1);
  json s = {{"clips", N},
            {"clips_ok", n},
            {"clips_skipped", skipped},
            {"success_rate", succ / dn},
            {"fall_rate", fell / dn},
            {"mpjpe_m", mpjpe / dn},
            {"root_drift_m", drift / dn},
            {"mean_fraction_of_frames_tracked", frac_ok / dn},
            {"assist_force_n", a.assist},
            {"gain_scale", a.gain_scale},
            {"velocity_feedforward", !a.no_ff},
            {"control_steps_per_s", frames / std::max(secs, 1e-9)}};
  const char* controller = a.samcon ? "samcon" : a.mpc ? "samcon-mpc" : a.balance ? "balance expert" : "PD";
  s["controller"] = controller;
  std::printf("track-pd (%s, %s, %d clips, assist %.0f N, gains x%g%s): success %.1f%%, fall %.1f%%, MPJPE %.1f mm, root drift "
              "%.2f m, frames tracked %.1f%%, %.0f control steps/s\n",
              controller, a.clips.bvh.empty() ? (a.clips.split + " split").c_str() : "given files", n, a.assist, a.gain_scale, a.no_ff ? ", no feed-forward" : "", 100 * succ / dn,
              100 * fell / dn, 1e3 * mpjpe / dn, drift / dn, 100 * frac_ok / dn, s["control_steps_per_s"].get<double>());
  write_json(a.clips.out, {{"command", "track-pd"}, {"split", a.clips.split}, {"summary", s}, {"clips", rows}});
}

// ---- t2m export / t2m render ----
struct OneArgs {
  std::string bvh, qpos, out, frames_dir, mode;
  double assist = 0;
  int width = 640, height = 480, max_frames = 0;
  bool shadows = false;
};

sim::QposTrajectory trajectory_for(const std::shared_ptr<const sim::Humanoid>& h, const OneArgs& a) {
  if (a.bvh.empty() == a.qpos.empty()) throw Error("give exactly one of --bvh FILE or --qpos FILE.json");
  if (!a.qpos.empty()) {  // a state sequence (e.g. from track-pd --export-dir): used as it is
    sim::QposTrajectory q = sim::load_trajectory_json(*h, a.qpos);
    if (a.max_frames > 0 && q.frames > a.max_frames) {
      q.frames = a.max_frames;
      q.qpos.resize((size_t)q.frames * q.nq);
      q.qvel.resize((size_t)q.frames * q.nv);
    }
    return q;
  }
  sim::QposTrajectory q = sim::retarget(*h, load_motion(a.bvh));
  if (a.max_frames > 0 && q.frames > a.max_frames) {
    q.frames = a.max_frames;
    q.qpos.resize((size_t)q.frames * q.nq);
    q.qvel.resize((size_t)q.frames * q.nv);
  }
  if (a.mode == "replay") return q;
  if (a.mode != "pd") throw Error("--mode must be 'replay' or 'pd' (got '" + a.mode + "')");
  sim::Env env(h, sim::EnvOptions{.substeps = sim::kSubsteps, .assist_force = a.assist});
  const sim::PdResult r = sim::track_pd(env, q);
  std::printf("pd: success %d, MPJPE %.1f mm, root drift %.2f m, fell %d, assist %.0f N\n", r.success,
              1e3 * r.mpjpe_m, r.root_drift_m, r.fell, a.assist);
  return r.simulated;
}

void run_export(const OneArgs& a) {
  if (a.out.empty()) throw Error("export: --out is required");
  auto h = sim::Humanoid::create();
  const sim::QposTrajectory q = trajectory_for(h, a);
  sim::export_bvh_file(*h, q, a.out);
  std::printf("wrote %s (%d frames, %s)\n", a.out.c_str(), q.frames, a.qpos.empty() ? a.mode.c_str() : "qpos");
}

void run_render(const OneArgs& a) {
  if (a.out.empty() && a.frames_dir.empty()) throw Error("render: give --out FILE.mp4 and/or --frames-dir DIR");
  auto h = sim::Humanoid::create();
  const sim::QposTrajectory q = trajectory_for(h, a);
  sim::RenderOptions ro;
  ro.width = a.width, ro.height = a.height, ro.shadows = a.shadows;
  const auto t0 = std::chrono::steady_clock::now();
  const int n = sim::render_trajectory(h, q, a.out, a.frames_dir, ro);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("rendered %d frames (%dx%d) in %.1f s (%.1f fps)%s%s%s%s\n", n, a.width, a.height, s, n / s,
              a.out.empty() ? "" : " -> ", a.out.c_str(), a.frames_dir.empty() ? "" : " + PNGs in ",
              a.frames_dir.c_str());
}

void add_one_options(CLI::App* c, OneArgs& a, const char* mode) {
  a.mode = mode;
  c->add_option("--bvh", a.bvh, "input BVH clip");
  c->add_option("--qpos", a.qpos, "input state sequence (t2m-qpos-1 JSON), used as it is (--mode ignored)");
  c->add_option("--mode", a.mode, "for --bvh: replay (kinematic) or pd (simulate the PD tracker)")
      ->capture_default_str();
  c->add_option("--assist", a.assist, "upward assist force on the root in N (pd mode; default 0 = none)");
  c->add_option("--max-frames", a.max_frames, "use at most N frames (0 = all)");
}

void add_sim_commands(CLI::App& app) {
  static ClipArgs rt;
  auto* r = app.add_subcommand("retarget", "retarget BVH clips to the humanoid and report the replay joint error");
  add_clip_options(r, rt, "all");
  r->callback([] { run_retarget(rt); });

  static PdArgs pd;
  auto* p = app.add_subcommand("track-pd", "PD tracking baseline on held-out clips (success, MPJPE, drift, falls)");
  add_clip_options(p, pd.clips, "test");
  p->add_option("--assist", pd.assist, "upward assist force on the root, N (default 0: no assist)");
  p->add_flag("--no-ff", pd.no_ff, "disable the velocity feed-forward");
  p->add_option("--gain-scale", pd.gain_scale, "multiply every PD gain (kp and kd) by this factor")
      ->capture_default_str();
  p->add_flag("--balance", pd.balance, "add stance-leg balance feedback (the BFM's expert, sim/balance_tracker.h)");
  p->add_option("--com-kp", pd.bo.com_kp, "balance: centre-of-mass stiffness, 1/s^2")->capture_default_str();
  p->add_option("--com-kd", pd.bo.com_kd, "balance: centre-of-mass damping, 1/s")->capture_default_str();
  p->add_option("--root-kp", pd.bo.root_kp, "balance: root orientation stiffness, N m/rad")->capture_default_str();
  p->add_option("--root-kd", pd.bo.root_kd, "balance: root orientation damping, N m s/rad")->capture_default_str();
  p->add_option("--max-force", pd.bo.max_force, "balance: horizontal virtual force cap, N")->capture_default_str();
  p->add_flag("--torque-at-hips-only", pd.bo.torque_at_hips_only, "balance: root torque through the stance hips only");
  p->add_option("--action-noise", pd.bo.action_noise,
                "balance: Gaussian noise std added to every target in [-1, 1] action units (seed = clip index)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 2.0));
  p->add_option("--export-dir", pd.export_dir, "write the simulated motion of every clip here (NAME.bvh and NAME.qpos.json; with --samcon or --samcon-mpc also NAME.ctrl.json, the actuator targets per control step)");
  p->add_flag("--resume", pd.resume,
              "with --export-dir and a search: skip clips whose NAME.ctrl.json is there (finished earlier; the "
              "seeds stay those of an uninterrupted run); the summary covers the clips run now");
  p->add_flag("--samcon", pd.samcon,
              "search offsets to the balance expert's targets per 0.1 s window (SAMCON, sim/samcon.h; slow: "
              "~80 s per 6 s clip at 512 samples on 2 threads)");
  p->add_option("--samcon-samples", pd.so.samples, "samcon: candidates per window")->capture_default_str()->check(CLI::PositiveNumber);
  p->add_option("--samcon-beam", pd.so.beam, "samcon: states kept per window")->capture_default_str()->check(CLI::PositiveNumber);
  p->add_option("--samcon-window", pd.so.window, "samcon: control steps per window")->capture_default_str()->check(CLI::PositiveNumber);
  p->add_option("--samcon-sigma", pd.so.sigma, "samcon: std of the per-hinge target offset, rad")->capture_default_str()->check(CLI::Range(0.0, 1.0));
  p->add_option("--samcon-seed", pd.so.seed, "samcon: seed (clip i uses seed + i)")->capture_default_str();
  p->add_flag("--samcon-mpc", pd.mpc,
              "closed-loop search: plan each 0.1 s window from the state the body is in (sim/samcon_mpc.h; "
              "--samcon-window, --samcon-sigma and --samcon-seed apply; ~6 s per second of motion on 2 threads)");
  p->add_option("--mpc-samples", pd.mo.samples, "samcon-mpc: candidates per window")->capture_default_str()->check(CLI::PositiveNumber);
  p->add_option("--mpc-horizon", pd.mo.horizon, "samcon-mpc: look-ahead in windows")->capture_default_str()->check(CLI::PositiveNumber);
  p->add_option("--mpc-carry", pd.mo.carry, "samcon-mpc: share of the previous offset new candidates start from")->capture_default_str()->check(CLI::Range(0.0, 1.0));
  p->add_option("--mpc-temperature", pd.mo.temperature, "samcon-mpc: 0 = apply the cheapest candidate; > 0 = the survivors' cost-weighted mean offset (relative temperature, e.g. 0.1)")->capture_default_str()->check(CLI::NonNegativeNumber);
  p->add_option("--mpc-size-cost", pd.mo.size_cost, "samcon-mpc: cost per rad² of mean squared offset (m², added to the tracking cost; prefers small offsets)")->capture_default_str()->check(CLI::NonNegativeNumber);
  p->add_option("--mpc-change-cost", pd.mo.change_cost, "samcon-mpc: cost per rad² of mean squared change from the previous window's offset (prefers persistent offsets)")->capture_default_str()->check(CLI::NonNegativeNumber);
  p->add_flag("--mpc-lower-body", pd.mpc_lower_body, "samcon-mpc: offsets on the trunk and leg hinges only (30 of 60); arms, neck and head follow the expert");
  p->add_option("--target-noise", pd.mo.target_noise, "samcon-mpc: Gaussian noise on every applied target, rad (robustness)")->capture_default_str()->check(CLI::Range(0.0, 1.0));
  p->add_option("--mpc-student", pd.mpc_student, "samcon-mpc, DAgger: this BFM policy drives the body (a share --mpc-student-share of the windows, the planner the rest) while the planner still plans every window; the export then labels the student's states with the planner's choice")->check(CLI::ExistingFile);
  p->add_option("--mpc-student-share", pd.mo.driver_share, "samcon-mpc with --mpc-student: share of the windows the student drives")->capture_default_str()->check(CLI::Range(0.0, 1.0));
  p->callback([p] {
    if (pd.samcon && pd.mpc) throw Error("track-pd: --samcon and --samcon-mpc exclude each other");
    for (const char* o : {"--mpc-samples", "--mpc-horizon", "--mpc-carry", "--mpc-temperature", "--mpc-size-cost",
                          "--mpc-change-cost", "--mpc-lower-body", "--target-noise", "--mpc-student", "--mpc-student-share"})
      if (!pd.mpc && p->count(o) > 0) throw Error(std::string("track-pd: ") + o + " needs --samcon-mpc");
    if ((pd.samcon || pd.mpc) && pd.assist != 0) throw Error("track-pd: --samcon / --samcon-mpc do not take --assist");
    if (pd.resume && (pd.export_dir.empty() || !(pd.samcon || pd.mpc)))
      throw Error("track-pd: --resume needs --export-dir and --samcon or --samcon-mpc");
    if (p->count("--mpc-student-share") > 0 && pd.mpc_student.empty())
      throw Error("track-pd: --mpc-student-share needs --mpc-student");
    run_track_pd(pd);
  });

  static OneArgs ex;
  auto* e = app.add_subcommand("export", "simulated (pd) or replayed motion of a clip -> BVH (data layout)");
  add_one_options(e, ex, "pd");
  e->add_option("--out", ex.out, "output .bvh")->required();
  e->callback([] { run_export(ex); });

  static OneArgs rd;
  auto* v = app.add_subcommand("render", "render a clip (replayed or simulated) offscreen to MP4 / PNG frames");
  add_one_options(v, rd, "replay");
  v->add_option("--out", rd.out, "output .mp4");
  v->add_option("--frames-dir", rd.frames_dir, "also write PNG frames here");
  v->add_option("--width", rd.width, "frame width (even)")->capture_default_str();
  v->add_option("--height", rd.height, "frame height (even)")->capture_default_str();
  v->add_flag("--shadows", rd.shadows, "render shadows (off by default)");
  v->callback([] { run_render(rd); });
}

}  // namespace

T2M_COMMAND(add_sim_commands);
