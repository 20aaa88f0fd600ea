// train_promotion_posture.cpp — `t2m train promotion --variant posture`: PRO-Motion's posture diffuser on our
// PoseScript-style set (key poses of the Bandai TRAIN split and their mirrors, posture_script_set.h), resumable in
// chunks (--stop-at, --resume). At the end of the full run (or of every chunk with --set eval=1) it writes
// OUT/promotion_posture.t2mckpt, the planner table OUT/promotion_planner.json (mined from the same train set),
// and OUT/summary.json with the val-split diffusion loss and the posecode agreement of sampled poses with
// test-split scripts (see docs/PROMOTION.md). --ship PATH copies the checkpoint to PATH and the planner table next to
// it (promotion_planner.json).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "models/data/dataset.h"
#include "models/data/loader.h"
#include "models/data/splits.h"
#include "models/promotion/planner_table.h"
#include "models/promotion/posture_agreement.h"
#include "models/promotion/posecodes.h"
#include "models/promotion/posture_diffuser_sampler.h"
#include "models/promotion/posture_diffuser_train.h"
#include "models/promotion/posture_script_set.h"
#include "nn/checkpoint.h"
#include "nn/train_state.h"
#include "tensor/parallel.h"
#include "tools/text_data.h"
#include "tools/train_variants.h"

namespace {

namespace fs = std::filesystem;
namespace pm = t2m::promotion;
using json = nlohmann::json;
using t2m::Error;

void train_posture(const t2m::cli::VariantTrainArgs& a) {
  a.check_keys({"width", "layers", "heads", "text_dim", "text_layers", "max_tokens", "cond_drop", "eval",
                "eval_items", "agree_scripts", "agree_samples", "guidance"});
  if (a.threads > 0) t2m::set_num_threads(a.threads);
  pm::PostureTrainConfig tc;
  if (a.steps > 0) tc.steps = a.steps;
  if (a.batch > 0) tc.batch = a.batch;
  if (a.lr > 0) tc.lr = a.lr;
  if (a.save_every > 0) tc.save_every = a.save_every;
  tc.stop_at = a.stop_at;
  tc.seed = a.seed ? a.seed : 1;
  tc.warmup = std::min<int64_t>(100, tc.steps / 10);
  tc.validate();
  const std::string out = a.out.empty() ? t2m::cli::default_output_dir("promotion-posture") : a.out;
  fs::create_directories(out);

  // Data: manifest -> splits -> clips -> key poses + scripts.
  const std::string mpath = a.manifest.empty() ? t2m::data::default_cache_dir() + "/bandai/manifest.json" : a.manifest;
  if (!fs::exists(mpath)) throw Error("train promotion posture: no manifest at " + mpath + " (run `t2m data prepare`)");
  const auto manifest = t2m::data::load_manifest(mpath);
  std::vector<std::string> names;
  for (const auto& c : manifest.clips) names.push_back(c.name);
  const auto splits = t2m::data::assign_splits(names);
  using t2m::data::Split;
  const auto train_clips = t2m::data::load_split_clips(manifest, splits, Split::train, a.threads);
  const auto val_clips = t2m::data::load_split_clips(manifest, splits, Split::val, a.threads);
  const auto test_clips = t2m::data::load_split_clips(manifest, splits, Split::test, a.threads);
  const pm::PoseStats stats = pm::pose_stats_from_feature_stats(t2m::data::clip_feature_stats(train_clips, true));
  const pm::PostureScriptSet train = pm::build_posture_script_set(train_clips, pm::kDefaultKeyFrames, true);
  const pm::PostureScriptSet val = pm::build_posture_script_set(val_clips, pm::kDefaultKeyFrames, false);
  const pm::PostureScriptSet test = pm::build_posture_script_set(test_clips, pm::kDefaultKeyFrames, false);

  pm::PostureDiffuserConfig mc;
  mc.width = a.get_int("width", mc.width);
  mc.layers = a.get_int("layers", mc.layers);
  mc.heads = a.get_int("heads", mc.heads);
  mc.text_dim = a.get_int("text_dim", mc.text_dim);
  mc.text_layers = a.get_int("text_layers", mc.text_layers);
  mc.max_tokens = a.get_int("max_tokens", mc.max_tokens);
  mc.cond_drop = a.get_double("cond_drop", mc.cond_drop);
  const t2m::text::Tokenizer tok = pm::script_tokenizer();
  mc.vocab = tok.vocab_size();
  t2m::Generator init(tc.seed);
  auto net = std::make_shared<pm::PostureDiffuser>(mc, init);
  std::fprintf(stderr, "train promotion posture: %d train / %d val / %d test key poses (Bandai, train with mirrors), "
               "%.2f M parameters\n", train.size(), val.size(), test.size(), net->num_parameters() / 1e6);
  const pm::PostureTrainData td = pm::make_posture_train_data(train, stats, tok, mc.max_tokens);
  const pm::PostureTrainPaths paths{out + "/train_state.t2mckpt", out + "/log.jsonl", out + "/loss.svg"};
  const pm::PostureTrainResult r = pm::train_posture_diffuser(*net, td, tc, paths, a.resume);
  std::fprintf(stderr, "train promotion posture: step %lld / %lld, smoothed loss %.4f, %.0f s in this run\n",
               (long long)r.steps, (long long)tc.steps, r.final_loss, r.seconds);
  if (r.steps < tc.steps && a.get_int("eval", 0) == 0) return;  // a chunk: evaluate at the end

  const pm::PostureTrainData vd = pm::make_posture_train_data(val, stats, tok, mc.max_tokens);
  const double val_loss = pm::posture_eval_loss(*net, vd, a.get_int("eval_items", 2144), 0);
  const double train_loss = pm::posture_eval_loss(*net, td, a.get_int("eval_items", 2144), 0);
  pm::PostureModel m{net, tok, stats,
                     {{"command", "t2m train promotion --variant posture"}, {"steps", r.steps},
                      {"train", tc.to_json()}, {"data", "Bandai-Namco train split key poses (8 per clip) + mirrors"},
                      {"val_loss", val_loss}}};
  const std::string ck = out + "/promotion_posture.t2mckpt", table_path = out + "/promotion_planner.json";
  pm::save_posture_model(m, ck);
  pm::PlannerTable table = pm::mine_planner_table(train, train_clips);
  table.source = {{"data", "Bandai-Namco train split, 8 key poses per clip + mirrors"}, {"items", train.size()},
                  {"command", "t2m train promotion --variant posture"}};
  pm::save_planner_table(table, table_path);
  pm::PostureSampleOptions so;
  so.guidance = a.get_double("guidance", 2.0);
  const json agree = pm::posture_agreement(m, test, train, (int)a.get_int("agree_scripts", 64),
                                           (int)a.get_int("agree_samples", 4), so, 7).to_json(so);
  const json summary = {{"steps", r.steps}, {"val_loss", val_loss}, {"train_loss_eval", train_loss},
                        {"eval_items", a.get_int("eval_items", 2144)}, {"test_agreement", agree},
                        {"parameters", net->num_parameters()}, {"model", mc.to_json()}, {"train", tc.to_json()}};
  t2m::nn::write_file_atomic(out + "/summary.json", summary.dump(1) + "\n");
  std::printf("%s\n", summary.dump(1).c_str());
  if (!a.ship.empty()) {
    t2m::cli::copy_file_atomic(ck, a.ship);
    const std::string tp = (fs::path(a.ship).parent_path() / "promotion_planner.json").string();
    t2m::cli::copy_file_atomic(table_path, tp);
    std::printf("shipped %s and %s\n", a.ship.c_str(), tp.c_str());
  }
}

}  // namespace

T2M_TRAIN_VARIANT("promotion", "posture", "PRO-Motion posture diffuser (script -> key pose DDPM) + planner table",
                  train_posture);
