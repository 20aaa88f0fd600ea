// eval_generation.cpp — evaluation prompts -> Text2BFM generations (parallel over items) -> raw features.
#include "models/text2bfm/eval_generation.h"

#include <chrono>
#include <cstdio>
#include <ctime>
#include <exception>
#include <mutex>
#include <omp.h>

#include "models/data/features.h"
#include "sim/retarget.h"

namespace t2m::text2bfm {

namespace {

uint64_t splitmix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

double process_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

std::string padded(int64_t v, int width) {
  std::string s = std::to_string(v);
  return std::string(s.size() < (size_t)width ? width - s.size() : 0, '0') + s;
}

}  // namespace

std::vector<float> trajectory_features(const sim::Humanoid& h, const sim::QposTrajectory& traj, int first) {
  if (first < 0 || first >= traj.frames)
    throw Error("eval text2bfm: trajectory of " + std::to_string(traj.frames) + " frames has no frames from " +
                std::to_string(first));
  sim::QposTrajectory q = traj;
  q.frames = traj.frames - first;
  q.qpos.assign(traj.qpos.begin() + (size_t)first * traj.nq, traj.qpos.end());
  q.qvel.assign(traj.qvel.begin() + (size_t)first * traj.nv, traj.qvel.end());
  return data::motion_to_features(sim::motion_from_qpos(h, q));
}

uint64_t sample_seed(uint64_t seed, int64_t item, int64_t sample) {
  return splitmix64(splitmix64(splitmix64(seed) ^ (uint64_t)item) ^ (uint64_t)sample);
}

EvalGenResult generate_eval_motions(Text2BfmModels& m, const std::vector<EvalItem>& items, const EvalGenOptions& opt,
                                    const std::function<void(int64_t, int64_t)>& progress) {
  const int64_t n = (int64_t)items.size();
  if (n == 0) throw Error("eval text2bfm: no prompts to generate");
  for (int64_t i = 0; i < n; ++i)
    if (items[i].frames < 1 || items[i].caption.empty())
      throw Error("eval text2bfm: item " + std::to_string(i) + " needs a caption and frames >= 1");
  if (opt.mm_prompts < 0 || opt.mm_prompts > n)
    throw Error("eval text2bfm: mm_prompts must be in [0, " + std::to_string(n) + "], got " +
                std::to_string(opt.mm_prompts));
  if (opt.mm_prompts > 0 && opt.samples < 2)
    throw Error("eval text2bfm: MultiModality needs samples >= 2, got " + std::to_string(opt.samples));
  if (opt.jobs < 1) throw Error("eval text2bfm: jobs must be >= 1");
  opt.gen.validate();

  // Work list: (item, sample, prompt id).
  std::vector<int64_t> prompt_of(n, -1);
  for (int64_t k = 0; k < opt.mm_prompts; ++k) prompt_of[(k * n) / opt.mm_prompts] = k;
  struct Job {
    int64_t item, sample;
  };
  std::vector<Job> jobs;
  for (int64_t i = 0; i < n; ++i) {
    const int64_t S = prompt_of[i] >= 0 ? opt.samples : 1;
    for (int64_t s = 0; s < S; ++s) jobs.push_back({i, s});
  }
  EvalGenResult r;
  r.entries.resize(jobs.size());
  std::vector<Generation> gens(jobs.size());
  const auto t0 = std::chrono::steady_clock::now();
  const double c0 = process_cpu_s();
  std::mutex mu;
  std::exception_ptr err;
  int64_t done = 0;
  const int64_t total = (int64_t)jobs.size();
#pragma omp parallel for schedule(dynamic, 1) num_threads(opt.jobs)
  for (int64_t j = 0; j < total; ++j) {
    {
      std::lock_guard<std::mutex> lk(mu);
      if (err) continue;
    }
    try {
      const Job& jb = jobs[j];
      const EvalItem& it = items[jb.item];
      GenerateOptions go = opt.gen;
      go.seed = sample_seed(opt.seed, jb.item, jb.sample);
      go.length_s = double(it.frames) * sim::kControlDt;
      go.start_qpos = it.start_qpos, go.start_qvel = it.start_qvel;
      Generation g = generate_motion(m, it.caption, go);
      eval::MotionEntry& e = r.entries[j];
      e.caption = it.caption;
      e.prompt = prompt_of[jb.item];
      e.file = e.prompt >= 0 ? padded(jb.item, 4) + "_" + padded(jb.sample, 2) + ".npy" : padded(jb.item, 4) + ".npy";
      e.features = trajectory_features(*m.humanoid, g.traj, 1);
      e.frames = (int64_t)e.features.size() / data::kFeatureDim;
      g.traj = {};
      g.obs.clear();
      gens[j] = std::move(g);
      std::lock_guard<std::mutex> lk(mu);
      ++done;
      if (progress) progress(done, total);
    } catch (...) {
      std::lock_guard<std::mutex> lk(mu);
      if (!err) err = std::current_exception();
    }
  }
  if (err) std::rethrow_exception(err);
  EvalGenStats& st = r.stats;
  st.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  st.cpu_s = process_cpu_s() - c0;
  double fall_sum = 0;
  r.item_fell.assign(n, false);
  for (int64_t j = 0; j < total; ++j)
    if (jobs[j].sample == 0) r.item_fell[jobs[j].item] = gens[j].falls > 0;
  for (const Generation& g : gens) {
    ++st.generations;
    st.control_steps += g.z.size(0);
    st.text_s += g.times.text;
    st.sample_s += g.times.sample;
    st.decode_s += g.times.decode;
    st.rollout_s += g.times.rollout;
    if (g.falls > 0) {
      ++st.fell;
      fall_sum += g.first_fall_s;
    }
  }
  st.mean_first_fall_s = st.fell > 0 ? fall_sum / double(st.fell) : 0.0;
  return r;
}

}  // namespace t2m::text2bfm
