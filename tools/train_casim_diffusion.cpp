// train_casim_diffusion.cpp — `t2m train casim --variant diff-cls | diff-mhsa | diff-mhca`: the MDM-style
// diffusion half of the CASIM baseline (issue 11, docs/CASIM.md) on the Bandai TRAIN split, conditioned on the
// frozen text encoder's sentence embedding (cls) or its token features through the CASIM text-motion aligner
// (mhsa: encoder denoiser, mhca: decoder denoiser). Resumable chunks (--resume, --stop-at), progress bar, JSONL
// log + SVG plot in --out; every chunk writes OUT/casim_diff_<variant>.t2mckpt and OUT/summary.json (+ --ship PATH
// when the run is complete).
// --set keys: width, layers, heads, mlp_ratio, window (frames), cond_dropout, guidance, sample_steps,
//   paraphrases, text (text encoder checkpoint).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "models/casim/diffusion_checkpoint.h"
#include "models/casim/diffusion_train.h"
#include "models/data/dataset.h"
#include "models/data/splits.h"
#include "models/text/text_motion_model.h"
#include "nn/checkpoint.h"
#include "tensor/parallel.h"
#include "tools/text_data.h"
#include "tools/train_variants.h"

namespace {

namespace fs = std::filesystem;
namespace cs = t2m::casim;
using json = nlohmann::json;
using t2m::Error;
using t2m::cli::VariantTrainArgs;

constexpr const char* kData = "Bandai-Namco-Research-Motiondataset 1+2 (CC BY-NC 4.0)";

void train_diffusion_variant(const VariantTrainArgs& a, cs::Conditioning cond) {
  a.check_keys({"width", "layers", "heads", "mlp_ratio", "window", "cond_dropout", "guidance", "sample_steps",
                "paraphrases", "text"});
  if (a.threads > 0) t2m::set_num_threads(a.threads);
  const std::string text_p = a.get("text", a.checkpoints + "/text_encoder.t2mckpt");
  if (!fs::is_regular_file(text_p)) throw Error("train casim: missing " + text_p + " (make it with `t2m train text`)");
  const auto tb = t2m::text::load_text_motion_model(text_p);
  const auto& enc = dynamic_cast<const t2m::text::TextMotionModel&>(*tb.model).text();

  // Small CPU config (docs/CASIM.md): width 128, 4 layers, 4 heads, MLP x2, windows of 64 frames, 1000 steps of 16.
  cs::DenoiserConfig mc;
  mc.cond = cond;
  mc.width = a.get_int("width", 128);
  mc.layers = a.get_int("layers", 4);
  mc.heads = a.get_int("heads", 4);
  mc.mlp_ratio = a.get_int("mlp_ratio", 2);
  mc.cond_dropout = a.get_double("cond_dropout", 0.1);
  mc.text_dim = enc.config().dim, mc.pooled_dim = enc.config().embed_dim;
  cs::DiffusionTrainConfig tc;
  tc.window = a.get_int("window", 64);
  tc.paraphrases = (int)a.get_int("paraphrases", 8);
  tc.steps = a.steps ? a.steps : 1000;
  tc.batch = a.batch ? a.batch : 16;
  if (a.lr > 0) tc.lr = a.lr;
  tc.save_every = a.save_every ? a.save_every : 25;
  tc.warmup = std::min<int64_t>(tc.warmup, tc.steps / 10);
  tc.stop_at = a.stop_at;
  tc.seed = a.seed;
  tc.validate();
  fs::create_directories(a.out);

  const auto train = a.split_clips(t2m::data::Split::train);
  const auto stats = t2m::data::clip_feature_stats(train, true);
  t2m::Generator g(a.seed);
  auto model = std::make_shared<cs::CasimDenoiser>(mc, g);
  std::fprintf(stderr, "train casim %s: %zu train clips, %lld parameters, window %lld frames\n", a.variant.c_str(),
               train.size(), (long long)model->num_parameters(), (long long)tc.window);
  const cs::DiffusionTrainPaths p{a.out + "/train_state.t2mckpt", a.out + "/log.jsonl", a.out + "/loss.svg"};
  const auto r = cs::train_diffusion(*model, tb, train, stats, tc, p, a.resume, "train casim " + a.variant);

  // Wall and CPU time accumulate over the chunks of one run (summary.json of the previous chunk).
  double wall = r.seconds, cpu = r.cpu_seconds;
  if (a.resume && fs::exists(a.out + "/summary.json")) {
    try {
      std::ifstream in(a.out + "/summary.json");
      const json prev = json::parse(in);
      wall += prev.value("wall_seconds_total", 0.0);
      cpu += prev.value("cpu_seconds_total", 0.0);
    } catch (const std::exception&) {
    }
  }
  cs::DiffusionBundle b;
  b.model = model;
  b.stats = stats;
  b.window = tc.window;
  b.sampler.steps = a.get_int("sample_steps", 50);
  b.sampler.guidance = a.get_double("guidance", 2.5);
  b.train = {{"command", a.command_line()}, {"steps", r.steps}, {"config", tc.to_json()},
             {"data", std::string(kData) + ", train split, captions from its labels"}, {"text_encoder", text_p},
             {"wall_seconds_total", wall}, {"cpu_seconds_total", cpu}};
  const std::string ckpt = a.out + "/casim_" + std::string(a.variant == "diff-cls" ? "diff_cls" :
                                                           a.variant == "diff-mhsa" ? "diff_mhsa" : "diff_mhca") +
                           ".t2mckpt";
  cs::save_diffusion_checkpoint(b, ckpt);
  const json summary = {{"checkpoint", ckpt},        {"steps", r.steps},       {"target_steps", tc.steps},
                        {"final_loss_smoothed", r.final_loss},                 {"wall_seconds_chunk", r.seconds},
                        {"cpu_seconds_chunk", r.cpu_seconds},                  {"wall_seconds_total", wall},
                        {"cpu_seconds_total", cpu},  {"parameters", model->num_parameters()},
                        {"model", mc.to_json()},     {"train", b.train},       {"clips", train.size()}};
  t2m::nn::write_file_atomic(a.out + "/summary.json", summary.dump(1) + "\n");
  if (r.steps >= tc.steps && !a.ship.empty()) t2m::cli::copy_file_atomic(ckpt, a.ship);
  std::printf("casim %s: step %lld / %lld, x0 loss %.4f (smoothed, train split); %.0f s wall, %.0f s CPU in total\n"
              "checkpoint %s%s%s\n",
              a.variant.c_str(), (long long)r.steps, (long long)tc.steps, r.final_loss, wall, cpu, ckpt.c_str(),
              r.steps >= tc.steps && !a.ship.empty() ? ", shipped to " : "",
              r.steps >= tc.steps ? a.ship.c_str() : " (rerun with --resume to continue)");
}

void train_diff_cls(const VariantTrainArgs& a) { train_diffusion_variant(a, cs::Conditioning::cls); }
void train_diff_mhsa(const VariantTrainArgs& a) { train_diffusion_variant(a, cs::Conditioning::mhsa); }
void train_diff_mhca(const VariantTrainArgs& a) { train_diffusion_variant(a, cs::Conditioning::mhca); }

}  // namespace

T2M_TRAIN_VARIANT("casim", "diff-cls", "MDM diffusion conditioned on the pooled sentence embedding ([CLS])",
                  train_diff_cls);
T2M_TRAIN_VARIANT("casim", "diff-mhsa", "CASIM-MDM: token embeddings + self-attention aligner (encoder denoiser)",
                  train_diff_mhsa);
T2M_TRAIN_VARIANT("casim", "diff-mhca", "CASIM-MDM: token embeddings + cross-attention aligner (decoder denoiser)",
                  train_diff_mhca);
