// cmd_eval_promotion_go.cpp — `t2m eval promotion-go --out DIR`: APE / AVE (PRO-Motion Tab 2) of the go-diffuser fed
// the GROUND-TRUTH key poses of held-out clips, against the clips themselves, next to a key-pose interpolation
// baseline (body linearly interpolated between the key poses, no root motion).
//   t2m eval promotion-go --out DIR [--checkpoints D] [--split test] [--clips 32] [--seed 0] [--threads T]
// Clips: the split's clips with >= T frames sorted by name, every k-th so that --clips are taken; the centred
// window of T frames of each; key poses at pose.h's frames of the window; one DDPM sample each (seed), batches of
// 16. DIR/eval.json gets both rows with provenance.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "models/data/dataset.h"
#include "models/data/loader.h"
#include "models/data/splits.h"
#include "models/promotion/go_diffuser_checkpoint.h"
#include "models/promotion/go_diffuser_eval.h"
#include "models/promotion/go_diffuser_train.h"
#include "models/promotion/pose.h"
#include "nn/checkpoint.h"
#include "tensor/parallel.h"
#include "tools/command.h"

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using t2m::Error;
namespace pm = t2m::promotion;
constexpr int D = t2m::data::kFeatureDim;

struct Args {
  std::string out, checkpoints = "models/checkpoints", manifest, split = "test";
  int clips = 32, threads = 0;
  uint64_t seed = 0;
  bool inpaint = false;
};

// Baseline: the window with no root motion and the pose dims linearly interpolated between the key frames.
std::vector<float> interpolate_keys(const std::vector<float>& win, int T, const std::vector<int>& kf) {
  std::vector<float> out(win.size(), 0.f);
  for (int t = 0; t < T; ++t) {
    size_t i = 0;
    while (i + 1 < kf.size() && kf[i + 1] < t) ++i;
    const int a = kf[i], b = kf[std::min(i + 1, kf.size() - 1)];
    const double w = b > a ? std::clamp((double)(t - a) / (b - a), 0.0, 1.0) : 0.0;
    for (int d = pm::kPoseFeatureBegin; d < pm::kPoseFeatureBegin + pm::kPoseDim; ++d)
      out[(size_t)t * D + d] = (float)((1 - w) * win[(size_t)a * D + d] + w * win[(size_t)b * D + d]);
  }
  return out;
}

void run(const Args& a) {
  if (a.threads > 0) t2m::set_num_threads(a.threads);
  if (a.clips < 1) throw Error("eval promotion-go: --clips must be >= 1");
  const std::string mpath = a.manifest.empty() ? t2m::data::default_cache_dir() + "/bandai/manifest.json" : a.manifest;
  const std::string gpath = a.checkpoints + "/promotion_go.t2mckpt";
  const pm::GoBundle go = pm::load_go_checkpoint(gpath);
  const int T = (int)go.model->config().frames, K = (int)go.model->config().keys;
  const auto manifest = t2m::data::load_manifest(mpath);
  std::vector<std::string> names;
  for (const auto& c : manifest.clips) names.push_back(c.name);
  const auto splits = t2m::data::assign_splits(names);
  const auto all = t2m::data::load_split_clips(manifest, splits, t2m::data::split_from_name(a.split), a.threads);
  std::vector<const t2m::data::MotionClip*> long_enough;
  for (const auto& c : all)
    if (c.frames >= T) long_enough.push_back(&c);
  std::sort(long_enough.begin(), long_enough.end(), [](auto* x, auto* y) { return x->name < y->name; });
  if (long_enough.empty()) throw Error("eval promotion-go: no " + a.split + " clip has " + std::to_string(T) + " frames");
  const size_t n = std::min<size_t>(a.clips, long_enough.size()), step = long_enough.size() / n;
  std::vector<std::vector<float>> truth, gen, base;
  std::vector<std::string> used;
  for (size_t i = 0; i < n; ++i) {
    const auto* c = long_enough[i * step];
    const int s = (c->frames - T) / 2;
    truth.emplace_back(c->features.begin() + (size_t)s * D, c->features.begin() + (size_t)(s + T) * D);
    used.push_back(c->name);
  }
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<int> kf = pm::key_frame_indices(T, K);
  const int B = 16;
  for (size_t b0 = 0; b0 < n; b0 += B) {
    const int bn = (int)std::min<size_t>(B, n - b0);
    std::vector<float> x;
    for (int i = 0; i < bn; ++i) {
      std::vector<float> w = truth[b0 + i];
      t2m::data::normalize_features(w, go.stats);
      x.insert(x.end(), w.begin(), w.end());
    }
    t2m::Tensor keys, key_frames;
    pm::batch_key_poses(t2m::Tensor::from_vector(x, {bn, T, D}), std::vector<int>(bn, T), K, &keys, &key_frames);
    t2m::Generator g(a.seed + 7919 * (b0 / B));
    const auto out = go.model->sample(keys, key_frames, g, 1.0, a.inpaint).to_vector<float>();
    for (int i = 0; i < bn; ++i) {
      std::vector<float> f(out.begin() + (size_t)i * T * D, out.begin() + (size_t)(i + 1) * T * D);
      t2m::data::denormalize_features(f, go.stats);
      gen.push_back(std::move(f));
      base.push_back(interpolate_keys(truth[b0 + i], T, kf));
    }
    std::fprintf(stderr, "eval promotion-go: %zu / %zu windows\n", b0 + bn, n);
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::vector<const std::vector<float>*> pt, pg, pb;
  for (size_t i = 0; i < n; ++i) pt.push_back(&truth[i]), pg.push_back(&gen[i]), pb.push_back(&base[i]);
  const auto rg = pm::ape_ave(pt, pg), rb = pm::ape_ave(pt, pb);
  const json j = {{"what", "go-diffuser fed the ground-truth key poses (" + std::to_string(K) + " per " +
                               std::to_string(T) + "-frame window) vs the same windows"},
                  {"data", "Bandai-Namco-Research-Motiondataset 1+2 (CC BY-NC 4.0), " + a.split + " split, " +
                               std::to_string(n) + " clips (every " + std::to_string(step) +
                               "th by name), centred windows"},
                  {"checkpoint", gpath}, {"seed", a.seed}, {"inpaint", a.inpaint}, {"wall_s", wall}, {"clips", used},
                  {"go_diffuser", rg.to_json()}, {"interpolation_no_root_motion", rb.to_json()}};
  fs::create_directories(a.out);
  t2m::nn::write_file_atomic(a.out + "/eval.json", j.dump(1) + "\n");
  std::printf("promotion go-diffuser on %zu %s windows (GT key poses): APE root %.3f m, traj %.3f m, local %.3f m, "
              "global %.3f m; AVE root %.4f, traj %.4f, local %.4f, global %.4f m^2\n"
              "  interpolation baseline: APE root %.3f, traj %.3f, local %.3f, global %.3f; AVE root %.4f, traj "
              "%.4f, local %.4f, global %.4f\n  %s/eval.json\n",
              n, a.split.c_str(), rg.ape_root, rg.ape_traj, rg.ape_local, rg.ape_global, rg.ave_root, rg.ave_traj,
              rg.ave_local, rg.ave_global, rb.ape_root, rb.ape_traj, rb.ape_local, rb.ape_global, rb.ave_root,
              rb.ave_traj, rb.ave_local, rb.ave_global, a.out.c_str());
}

void add_eval_promotion_go(CLI::App& app) {
  auto* grp = t2m::cli::command_group(app, "eval", "evaluate a model");
  auto a = std::make_shared<Args>();
  auto* c = grp->add_subcommand("promotion-go", "APE/AVE of the PRO-Motion go-diffuser from ground-truth key poses");
  c->add_option("--out", a->out, "output directory (eval.json)")->required();
  c->add_option("--checkpoints", a->checkpoints, "directory with promotion_go.t2mckpt")->capture_default_str();
  c->add_option("--manifest", a->manifest, "data manifest (default ~/.cache/t2m/bandai/manifest.json)");
  c->add_option("--split", a->split, "train, val or test")->capture_default_str();
  c->add_option("--clips", a->clips, "number of clips (windows)")->capture_default_str();
  c->add_option("--seed", a->seed, "sampling seed")->capture_default_str();
  c->add_flag("--inpaint", a->inpaint, "replace the key frames' poses in every x_0 estimate (go_diffuser.h)");
  c->add_option("--threads", a->threads, "threads (0 = default)");
  c->callback([a] { run(*a); });
}

}  // namespace

T2M_COMMAND(add_eval_promotion_go);
