// train_promotion_go.cpp — `t2m train promotion --variant go`: the PRO-Motion go-diffuser (Sec 3.4) on windows of
// the Bandai TRAIN split, conditioned on each window's own ground-truth key poses (pose.h's rule). Resumable chunks
// (--resume, --stop-at), progress bar, OUT/log.jsonl + loss.svg, OUT/promotion_go.t2mckpt (+ --ship PATH) and
// OUT/summary.json. --set keys: frames, keys, width, layers, heads, mlp_ratio, diffusion_steps, cond_drop,
// warmup. See docs/PROMOTION.md.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "models/data/dataset.h"
#include "models/data/loader.h"
#include "models/data/splits.h"
#include "models/promotion/go_diffuser_checkpoint.h"
#include "models/promotion/go_diffuser_train.h"
#include "nn/checkpoint.h"
#include "tools/text_data.h"
#include "tools/train_variants.h"

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using t2m::Error;
namespace pm = t2m::promotion;

void train_go(const t2m::cli::VariantTrainArgs& a) {
  a.check_keys({"frames", "keys", "width", "layers", "heads", "mlp_ratio", "diffusion_steps", "cond_drop", "warmup"});
  pm::GoDiffuserConfig mc;
  mc.frames = a.get_int("frames", mc.frames);
  mc.keys = a.get_int("keys", mc.keys);
  mc.width = a.get_int("width", mc.width);
  mc.layers = a.get_int("layers", mc.layers);
  mc.heads = a.get_int("heads", mc.heads);
  mc.mlp_ratio = a.get_int("mlp_ratio", mc.mlp_ratio);
  mc.diffusion_steps = a.get_int("diffusion_steps", mc.diffusion_steps);
  mc.cond_drop = a.get_double("cond_drop", mc.cond_drop);
  mc.validate();
  pm::GoTrainConfig tc;
  t2m::cli::apply_common_flags(a, tc);
  tc.warmup = a.get_int("warmup", tc.warmup);
  tc.validate();
  std::fprintf(stderr, "train promotion go: loading the train split ...\n");
  const auto clips = a.split_clips(t2m::data::Split::train);
  fs::create_directories(a.out);
  const auto stats = t2m::data::clip_feature_stats(clips);
  t2m::Generator g(a.seed);
  auto model = std::make_shared<pm::GoDiffuser>(mc, g);
  std::fprintf(stderr, "train promotion go: %zu train clips, go-diffuser %lld parameters, %s\n", clips.size(),
               (long long)model->num_parameters(), mc.to_json().dump().c_str());
  const pm::GoTrainPaths p{a.out + "/train_state.t2mckpt", a.out + "/log.jsonl", a.out + "/loss.svg"};
  const auto r = pm::train_go_diffuser(*model, clips, stats, tc, p, a.resume);

  pm::GoBundle b;
  b.model = model;
  b.stats = stats;
  b.train = {{"command", a.command_line()}, {"steps", r.steps}, {"config", tc.to_json()},
             {"data", "Bandai-Namco-Research-Motiondataset 1+2 (CC BY-NC 4.0), train split"}};
  const std::string ckpt = a.out + "/promotion_go.t2mckpt";
  pm::save_go_checkpoint(b, ckpt);
  const json summary = {{"checkpoint", ckpt}, {"steps", r.steps}, {"seconds_this_run", r.seconds},
                        {"final_loss_smoothed", r.final_loss}, {"parameters", model->num_parameters()},
                        {"clips", clips.size()}, {"train", b.train}, {"model", mc.to_json()}};
  t2m::nn::write_file_atomic(a.out + "/summary.json", summary.dump(1) + "\n");
  if (!a.ship.empty()) t2m::cli::copy_file_atomic(ckpt, a.ship);
  std::printf("promotion go: %lld steps, x0 loss %.4f (smoothed, train split); checkpoint %s%s%s\n",
              (long long)r.steps, r.final_loss, ckpt.c_str(), a.ship.empty() ? "" : ", shipped to ", a.ship.c_str());
}

}  // namespace

T2M_TRAIN_VARIANT("promotion", "go", "PRO-Motion go-diffuser: key poses -> whole motion (DDPM, cosine, 100 steps)",
                  train_go);
