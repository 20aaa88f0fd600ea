// train_casim_ar.cpp — `t2m train casim --variant vq | ar-cls | ar-tok`: the autoregressive half of the CASIM
// baseline (issue 11, docs/CASIM.md): the T2M-GPT motion tokenizer, then the token GPT conditioned on the pooled
// sentence feature (ar-cls) or on the token features (ar-tok, CASIM), on the Bandai TRAIN split. Resumable chunks
// (--resume, --stop-at), progress bar, JSONL log + SVG plot in --out; when a run reaches --steps it evaluates on
// the TEST split, writes OUT/summary.json and the checkpoint OUT/casim_<variant>.t2mckpt (+ --ship PATH).
// --set final=1: no training; the run's current state (stopped before --steps, e.g. when the CPU budget ran out)
// is evaluated and written as the checkpoint; its summary and provenance record the step it stopped at.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "models/casim/ar_checkpoint.h"
#include "models/casim/ar_codes.h"
#include "models/casim/ar_train.h"
#include "models/casim/vq_train.h"
#include "models/data/dataset.h"
#include "models/data/splits.h"
#include "nn/checkpoint.h"
#include "tools/text_data.h"
#include "tools/train_variants.h"

namespace {

namespace fs = std::filesystem;
namespace cs = t2m::casim;
using json = nlohmann::json;
using t2m::Error;
using t2m::cli::VariantTrainArgs;

constexpr const char* kData = "Bandai-Namco-Research-Motiondataset 1+2 (CC BY-NC 4.0)";
constexpr uint64_t kCaptionSeed = 7;  // test captions: make_caption(labels, 7, 0), as `t2m eval motions`

void finish(const VariantTrainArgs& a, const std::string& ckpt, const json& summary) {
  t2m::nn::write_file_atomic(a.out + "/summary.json", summary.dump(1) + "\n");
  if (!a.ship.empty()) t2m::cli::copy_file_atomic(ckpt, a.ship);
  std::printf("%s\ncheckpoint %s%s%s\n", summary.dump(1).c_str(), ckpt.c_str(), a.ship.empty() ? "" : ", shipped to ",
              a.ship.c_str());
}

void train_vq(const VariantTrainArgs& a) {
  a.check_keys({"width", "codes", "code_dim", "depth", "window", "final"});
  cs::VqVaeConfig mc;
  mc.width = a.get_int("width", mc.width);
  mc.codebook.codes = a.get_int("codes", mc.codebook.codes);
  mc.codebook.dim = a.get_int("code_dim", mc.codebook.dim);
  mc.depth = a.get_int("depth", mc.depth);
  cs::VqTrainConfig tc;
  tc.window = a.get_int("window", tc.window);
  t2m::cli::apply_common_flags(a, tc);
  fs::create_directories(a.out);
  const auto train = a.split_clips(t2m::data::Split::train);
  const auto stats = t2m::data::clip_feature_stats(train, true);
  t2m::Generator g(a.seed);
  auto model = std::make_shared<cs::VqVae>(mc, g);
  std::fprintf(stderr, "train casim vq: %zu train clips, %lld parameters (+ codebook %lld x %lld)\n", train.size(),
               (long long)model->num_parameters(), (long long)mc.codebook.codes, (long long)mc.codebook.dim);
  const cs::TrainPaths p{a.out + "/train_state.t2mckpt", a.out + "/log.jsonl", a.out + "/loss.svg"};
  const bool final_now = a.get_int("final", 0) != 0;
  if (final_now) tc.stop_at = 1;  // load the state, train nothing (the state is past step 1)
  const auto r = cs::train_vq(*model, train, stats, tc, p, a.resume || final_now);
  if (r.steps < tc.steps && !final_now) {
    std::printf("casim vq: chunk done at step %lld / %lld (%.0f s wall, %.0f s CPU); rerun with --resume\n",
                (long long)r.steps, (long long)tc.steps, r.seconds, r.cpu_seconds);
    return;
  }
  const auto test = a.split_clips(t2m::data::Split::test);
  const cs::VqEval ev = cs::vq_evaluate(*model, test, stats);
  cs::VqBundle b{model, stats, {{"command", a.command_line()}, {"steps", r.steps}, {"schedule_steps", tc.steps},
                                {"config", tc.to_json()},
                                {"data", std::string(kData) + ", train split"}}};
  const std::string ckpt = a.out + "/casim_vq.t2mckpt";
  cs::save_vq(b, ckpt);
  finish(a, ckpt, {{"checkpoint", ckpt}, {"steps", r.steps}, {"final_loss_smoothed", r.final_loss},
                   {"seconds_last_chunk", r.seconds}, {"cpu_seconds_last_chunk", r.cpu_seconds},
                   {"parameters", model->num_parameters()}, {"model", mc.to_json()}, {"train", b.train},
                   {"test", ev.to_json()}, {"test_data", std::string(kData) + ", test split, whole clips"}});
}

void train_ar(const VariantTrainArgs& a, cs::ArCond cond) {
  a.check_keys({"vq", "text", "codes_dir", "dim", "layers", "heads", "max_motion", "corrupt", "final"});
  const std::string vq_p = a.get("vq", a.checkpoints + "/casim_vq.t2mckpt");
  const std::string text_p = a.get("text", a.checkpoints + "/text_encoder.t2mckpt");
  for (const auto& [path, how] : {std::pair{vq_p, "t2m train casim --variant vq"}, {text_p, "t2m train text"}})
    if (!fs::is_regular_file(path)) throw Error("train casim: missing " + path + " (make it with `" + how + "`)");
  const cs::VqBundle vq = cs::load_vq(vq_p);
  const uint32_t crc = cs::file_crc(vq_p);
  const std::string cdir = a.get("codes_dir", t2m::data::default_cache_dir() + "/casimar");
  auto codes_of = [&](t2m::data::Split s) {
    const std::string path = cdir + "/codes_" + t2m::data::split_name(s) + ".json";
    return cs::ensure_code_set(path, crc, [&] {
      std::fprintf(stderr, "train casim: tokenizing the %s split -> %s\n", t2m::data::split_name(s), path.c_str());
      return cs::build_code_set(*vq.model, vq.stats, a.split_clips(s));
    });
  };
  const cs::CodeSet train = codes_of(t2m::data::Split::train);
  const cs::ArTextEncoder text(text_p);
  cs::ArGptConfig mc;
  mc.cond = cond;
  mc.codes = vq.model->config().codebook.codes;
  mc.text_dim = text.config().dim, mc.pooled_dim = text.config().embed_dim, mc.max_text = text.config().max_len;
  mc.dim = a.get_int("dim", mc.dim), mc.layers = a.get_int("layers", mc.layers);
  mc.heads = a.get_int("heads", mc.heads), mc.max_motion = a.get_int("max_motion", mc.max_motion);
  cs::ArTrainConfig tc;
  tc.corrupt = a.get_double("corrupt", tc.corrupt);
  t2m::cli::apply_common_flags(a, tc);
  fs::create_directories(a.out);
  t2m::Generator g(a.seed);
  auto model = std::make_shared<cs::ArGpt>(mc, g);
  std::fprintf(stderr, "train casim ar-%s: %zu code sequences, %lld parameters\n", cs::ar_cond_name(cond),
               train.items.size(), (long long)model->num_parameters());
  const cs::TrainPaths p{a.out + "/train_state.t2mckpt", a.out + "/log.jsonl", a.out + "/loss.svg"};
  const bool final_now = a.get_int("final", 0) != 0;
  if (final_now) tc.stop_at = 1;  // load the state, train nothing (the state is past step 1)
  const auto r = cs::train_ar(*model, train, text, tc, p, a.resume || final_now);
  if (r.steps < tc.steps && !final_now) {
    std::printf("casim ar-%s: chunk done at step %lld / %lld (%.0f s wall, %.0f s CPU); rerun with --resume\n",
                cs::ar_cond_name(cond), (long long)r.steps, (long long)tc.steps, r.seconds, r.cpu_seconds);
    return;
  }
  const cs::ArEval ev = cs::ar_evaluate(*model, codes_of(t2m::data::Split::test), text, kCaptionSeed);
  cs::ArBundle b{model, crc, {{"command", a.command_line()}, {"steps", r.steps}, {"schedule_steps", tc.steps},
                              {"config", tc.to_json()},
                              {"data", std::string(kData) + ", train split"}, {"vq", vq_p}, {"text_encoder", text_p}}};
  const std::string ckpt = a.out + "/casim_ar_" + cs::ar_cond_name(cond) + ".t2mckpt";
  cs::save_ar(b, ckpt);
  finish(a, ckpt, {{"checkpoint", ckpt}, {"steps", r.steps}, {"final_loss_smoothed", r.final_loss},
                   {"seconds_last_chunk", r.seconds}, {"cpu_seconds_last_chunk", r.cpu_seconds},
                   {"parameters", model->num_parameters()}, {"model", mc.to_json()}, {"train", b.train},
                   {"test_teacher_forced", ev.to_json()},
                   {"test_data", std::string(kData) + ", test split, captions make_caption(labels, 7, 0)"}});
}

void train_ar_cls(const VariantTrainArgs& a) { train_ar(a, cs::ArCond::cls); }
void train_ar_tok(const VariantTrainArgs& a) { train_ar(a, cs::ArCond::tok); }

}  // namespace

T2M_TRAIN_VARIANT("casim", "vq", "T2M-GPT motion tokenizer (VQ-VAE, EMA codebook, dead-code reset)", train_vq);
T2M_TRAIN_VARIANT("casim", "ar-cls", "token GPT conditioned on the pooled sentence feature (prefix token)",
                  train_ar_cls);
T2M_TRAIN_VARIANT("casim", "ar-tok", "token GPT conditioned on the text token features (CASIM, causal MHSA)",
                  train_ar_tok);
