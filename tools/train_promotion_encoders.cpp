// train_promotion_encoders.cpp — `t2m train promotion --variant encoders`: PRO-Motion's posture-planning encoders
// (pose Θ, script Φ; Sec 3.3) trained with InfoNCE on our PoseScript-style set of the Bandai TRAIN split (8 key
// poses per clip and its mirror, automatic posture scripts), then scored on the TEST split's set (group-of-32
// retrieval). Resumable chunks, progress bar, OUT/log.jsonl + loss.svg, OUT/promotion_encoders.t2mckpt (+ --ship)
// and OUT/summary.json. --set keys: embed, pose_hidden, word_dim, gru_hidden, warmup. See docs/PROMOTION.md.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "models/data/dataset.h"
#include "models/data/loader.h"
#include "models/data/splits.h"
#include "models/promotion/pose_text_encoders_train.h"
#include "nn/checkpoint.h"
#include "tools/text_data.h"
#include "tools/train_variants.h"

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using t2m::Error;
namespace pm = t2m::promotion;

void train_encoders(const t2m::cli::VariantTrainArgs& a) {
  a.check_keys({"embed", "pose_hidden", "word_dim", "gru_hidden", "warmup"});
  const auto tok = pm::posture_script_tokenizer();
  pm::PoseTextConfig mc;
  mc.embed = a.get_int("embed", mc.embed);
  mc.pose_hidden = a.get_int("pose_hidden", mc.pose_hidden);
  mc.word_dim = a.get_int("word_dim", mc.word_dim);
  mc.gru_hidden = a.get_int("gru_hidden", mc.gru_hidden);
  mc.vocab = tok.vocab_size();
  mc.validate();
  pm::EncodersTrainConfig tc;
  t2m::cli::apply_common_flags(a, tc);
  tc.warmup = a.get_int("warmup", tc.warmup);
  tc.validate();
  std::fprintf(stderr, "train promotion encoders: loading the train and test splits ...\n");
  const auto train = a.split_clips(t2m::data::Split::train);
  fs::create_directories(a.out);
  const auto stats = pm::pose_stats_from_feature_stats(t2m::data::clip_feature_stats(train));
  const auto set = pm::build_posture_script_set(train, pm::kDefaultKeyFrames, true);
  t2m::Generator g(a.seed);
  auto model = std::make_shared<pm::PoseTextEncoders>(mc, g);
  std::fprintf(stderr, "train promotion encoders: %d (key pose, script) pairs, %lld parameters\n", set.size(),
               (long long)model->num_parameters());
  const pm::EncodersTrainPaths p{a.out + "/train_state.t2mckpt", a.out + "/log.jsonl", a.out + "/loss.svg"};
  const auto r = pm::train_pose_text_encoders(*model, tok, set, stats, tc, p, a.resume);

  const auto test = a.split_clips(t2m::data::Split::test);
  const auto test_set = pm::build_posture_script_set(test, pm::kDefaultKeyFrames, false);
  const auto ret = pm::pose_text_retrieval(*model, tok, test_set, stats, 32);
  const std::string cmd = a.command_line();
  pm::PoseTextBundle b{model, tok, stats,
                       {{"command", cmd}, {"steps", r.steps}, {"config", tc.to_json()},
                        {"data", "Bandai-Namco-Research-Motiondataset 1+2 (CC BY-NC 4.0), train split key poses "
                                 "with our automatic posture scripts"}}};
  const std::string ckpt = a.out + "/promotion_encoders.t2mckpt";
  pm::save_pose_text_bundle(b, ckpt);
  const json summary = {{"checkpoint", ckpt}, {"steps", r.steps}, {"seconds_this_run", r.seconds},
                        {"final_loss_smoothed", r.final_loss}, {"gamma", model->gamma()},
                        {"parameters", model->num_parameters()}, {"train_pairs", set.size()},
                        {"test_retrieval", {{"split", "test"}, {"pairs", test_set.size()}, {"group", ret.group},
                                            {"groups", ret.groups}, {"pose_to_script_top1", ret.pose_to_script_top1},
                                            {"script_to_pose_top1", ret.script_to_pose_top1}}},
                        {"train", b.train}, {"model", mc.to_json()}};
  t2m::nn::write_file_atomic(a.out + "/summary.json", summary.dump(1) + "\n");
  if (!a.ship.empty()) t2m::cli::copy_file_atomic(ckpt, a.ship);
  std::printf("promotion encoders: %lld steps, InfoNCE %.4f (smoothed, train split); test split group-of-32 top-1: "
              "pose->script %.3f, script->pose %.3f; checkpoint %s\n",
              (long long)r.steps, r.final_loss, ret.pose_to_script_top1, ret.script_to_pose_top1, ckpt.c_str());
}

}  // namespace

T2M_TRAIN_VARIANT("promotion", "encoders",
                  "PRO-Motion posture-planning encoders: pose / script InfoNCE (Viterbi scores)", train_encoders);
