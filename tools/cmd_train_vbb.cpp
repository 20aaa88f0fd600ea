// cmd_train_vbb.cpp — `t2m train vbb`: the variational behavioral bottleneck (Text2BFM Eq 13) on the cached Eq 2
// policy latents of the train split, in resumable chunks; scores on the val and test splits (Table 4 columns).
//   t2m train vbb [--out DIR] [--bfm POLICY] [--text TEXT_CKPT] [--steps N] [--stop-at N] [--resume] [--lr X]
//                 [--compression 1|4|8|16] [--lambda-sem X] [--ship PATH] [--avg-pool [--export-pool PATH]]
//                 [--score CKPT] [--dropout X] ...
// Latents: ~/.cache/t2m/latents/<split>.t2mckpt (models/text2bfm/latent_cache.h), rebuilt when the BFM file's
// checksum changes. DIR (default ~/.cache/t2m/vbb/default): train_state.t2mckpt, log.jsonl, loss.svg, vbb.t2mckpt,
// summary.json. --avg-pool scores the average-pooling row instead of training (--export-pool PATH also writes it
// as a VBB checkpoint, vbb_average_pool.h, for `t2m train gen --vbb`); --score CKPT scores a saved VBB. Scores
// are printed raw and with ẑ projected onto the sphere ‖ẑ‖ = sqrt(d) (what generation feeds the policy; the
// pooling row's historic setting). See docs/VBB.md.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "autograd/no_grad.h"
#include "models/bfm/policy_checkpoint.h"
#include "models/text/text_motion_model.h"
#include "models/text2bfm/latent_cache.h"
#include "models/text2bfm/pipeline_checkpoints.h"
#include "models/text2bfm/vbb_average_pool.h"
#include "models/text2bfm/vbb_checkpoint.h"
#include "models/text2bfm/vbb_eval.h"
#include "models/text2bfm/vbb_trainer.h"
#include "nn/checkpoint.h"
#include "nn/progress.h"
#include "nn/train_log.h"
#include "tensor/parallel.h"
#include "tools/command.h"
#include "tools/text_data.h"

namespace {

namespace fs = std::filesystem;
namespace tb = t2m::text2bfm;
using json = nlohmann::json;
using t2m::Error;
using clock_type = std::chrono::steady_clock;

struct TrainVbbArgs {
  std::string out, bfm, text, latents, manifest, ship, export_pool, score;
  int64_t stop_at = 0, compression = 8, save_every = 200, log_every = 10, eval_every = 0;
  int threads = 0;
  bool resume = false, avg_pool = false;
  tb::VbbTrainConfig cfg;
};

std::string first_existing(const std::vector<std::string>& paths) {
  for (const auto& p : paths)
    if (fs::exists(p)) return p;
  return paths.front();
}

tb::LatentSet split_latents(const TrainVbbArgs& a, t2m::bfm::FbAgent& agent, const std::string& checksum,
                            t2m::data::Split split) {
  const std::string dir = a.latents.empty() ? t2m::cli::default_output_dir("latents") : a.latents;
  const std::string path = dir + "/" + t2m::data::split_name(split) + ".t2mckpt";
  const int L = agent.config().track_window;
  bool rebuilt = false;
  tb::LatentSet s = tb::ensure_latent_cache(path, checksum, L, [&] {
    const std::string mpath =
        a.manifest.empty() ? t2m::data::default_cache_dir() + "/bandai/manifest.json" : a.manifest;
    if (!fs::exists(mpath)) throw Error("train vbb: no manifest at " + mpath + " (run `t2m data prepare`)");
    const auto manifest = t2m::data::load_manifest(mpath);
    auto h = t2m::sim::Humanoid::create();
    std::unique_ptr<t2m::nn::Progress> bar;
    return tb::extract_split_latents(agent, *h, manifest, split, checksum, L, [&](int done, int total) {
      if (!bar) bar = std::make_unique<t2m::nn::Progress>(total, std::string("latents ") + t2m::data::split_name(split));
      bar->update(done);
    });
  }, &rebuilt);
  std::fprintf(stderr, "train vbb: %s latents %s: %d clips, %lld frames (BFM %s)\n", t2m::data::split_name(split),
               rebuilt ? "extracted" : "cached", s.clips(), (long long)s.total_frames(), checksum.c_str());
  return s;
}

void print_row(const char* split, const tb::VbbEvalResult& r, const char* how = "") {
  std::printf("  %s split (Bandai-Namco, %lld clips, %lld frames)%s: latent MSE %.4f, action KL (Eq 21) %.4f\n",
              split, (long long)r.clips, (long long)r.frames, how, r.latent_mse, r.action_kl);
}

void run_train_vbb(TrainVbbArgs a, const std::string& cmdline) {
  const auto t_start = clock_type::now();
  if (a.threads > 0) t2m::set_num_threads(a.threads);
  // --avg-pool alone (no --export-pool) scores any pooling length c >= 1 dividing --window (c = window: one mean
  // per window, closest to the paper's whole-clip m_avg); everything else needs a VBB compression.
  const bool any_c = a.avg_pool && a.export_pool.empty() && a.compression >= 1;
  if (!any_c && a.compression != 1 && a.compression != 4 && a.compression != 8 && a.compression != 16)
    throw Error("train vbb: --compression must be 1, 4, 8 or 16, got " + std::to_string(a.compression));
  if (any_c && a.cfg.window % a.compression != 0) a.cfg.window = a.compression;
  const int64_t in_dim = a.cfg.vbb.in_dim;
  if (!any_c) {
    const tb::VbbConfig c = tb::VbbConfig::with_compression(a.compression, in_dim);
    a.cfg.vbb.levels = c.levels;
  }
  const std::string bfm_path = a.bfm.empty() ? tb::PipelinePaths::in_dir("models/checkpoints").bfm : a.bfm;
  if (!fs::exists(bfm_path))
    throw Error("train vbb: no BFM policy at " + bfm_path + " (pass --bfm, e.g. one exported by `t2m train bfm "
                "--export-only --export PATH`)");
  const std::string checksum = tb::file_checksum(bfm_path);
  std::unique_ptr<t2m::bfm::FbAgent> agent = t2m::bfm::load_policy(bfm_path);
  a.cfg.vbb.in_dim = agent->config().z_dim;
  a.cfg.validate();

  const std::string out = a.out.empty() ? t2m::cli::default_output_dir("vbb/default") : a.out;
  const std::string state = out + "/train_state.t2mckpt";
  if (!a.avg_pool && a.score.empty() && fs::exists(state) && !a.resume)
    throw Error("train vbb: " + state + " exists; pass --resume to continue it or another --out");

  const tb::LatentSet val = split_latents(a, *agent, checksum, t2m::data::Split::val);
  const tb::LatentSet test = split_latents(a, *agent, checksum, t2m::data::Split::test);
  if (a.avg_pool) {  // the no-learning "average pooling" row
    std::printf("average pooling, compression %lld, window %lld:\n", (long long)a.compression, (long long)a.cfg.window);
    for (bool project : {true, false}) {
      const char* how = project ? ", Proj to the sphere" : ", plain mean";
      print_row("val", tb::evaluate_average_pooling(val, a.compression, a.cfg.window, agent.get(), 64, project), how);
      print_row("test", tb::evaluate_average_pooling(test, a.compression, a.cfg.window, agent.get(), 64, project), how);
    }
    if (!a.export_pool.empty()) {
      const int64_t d = agent->config().z_dim;
      const auto pool = tb::make_average_pooling_vbb(d, a.compression, std::max<int64_t>(128, (2 * d + 31) / 32 * 32));
      const auto rt = tb::evaluate_vbb(*pool, test, a.cfg.window, agent.get(), 64, true);
      tb::save_vbb(*pool, a.export_pool,
                   {{"command", cmdline}, {"bottleneck", "average pooling (vbb_average_pool.h), nothing learned"},
                    {"bfm", bfm_path}, {"bfm_checksum", checksum}, {"test_sphere", rt.to_json()}});
      std::printf("average pooling as a VBB checkpoint: %s\n", a.export_pool.c_str());
      print_row("test", rt, ", that checkpoint, Proj to the sphere");
    }
    return;
  }
  if (!a.score.empty()) {  // a saved VBB, raw and projected
    nlohmann::json info;
    const auto vbb = tb::load_vbb(a.score, &info);
    std::printf("%s (compression %lld, window %lld):\n", a.score.c_str(), (long long)vbb->config().compression(),
                (long long)a.cfg.window);
    for (bool project : {false, true}) {
      const char* how = project ? ", Proj to the sphere" : ", raw decoder output";
      print_row("val", tb::evaluate_vbb(*vbb, val, a.cfg.window, agent.get(), 64, project), how);
      print_row("test", tb::evaluate_vbb(*vbb, test, a.cfg.window, agent.get(), 64, project), how);
    }
    return;
  }
  const tb::LatentSet train = split_latents(a, *agent, checksum, t2m::data::Split::train);

  // Frozen text encoder: token features y_{j,k} of the captions (Eq 7).
  tb::TextFeatureFn text;
  int64_t text_dim = 0;
  std::shared_ptr<t2m::text::RetrievalBundle> tb_ptr;
  if (a.cfg.loss.lambda_sem > 0) {
    const std::string tpath =
        a.text.empty() ? first_existing({"models/checkpoints/text_encoder.t2mckpt",
                                         t2m::cli::default_output_dir("text_encoder") + "/text_encoder.t2mckpt"})
                       : a.text;
    tb_ptr = std::make_shared<t2m::text::RetrievalBundle>(t2m::text::load_text_motion_model(tpath));
    const auto* tm = dynamic_cast<const t2m::text::TextMotionModel*>(tb_ptr->model.get());
    if (!tm) throw Error("train vbb: " + tpath + " is not a text_encoder checkpoint");
    text_dim = tm->config().text.dim;
    text = [tb_ptr, tm](const std::vector<std::string>& captions) {
      const auto enc = t2m::text::encode_captions(tb_ptr->tokenizer, captions, tm->max_text_len());
      t2m::ag::NoGradGuard ng;
      return tb::TokenFeatures{tm->text().forward(enc.ids, enc.mask).tokens.data(), enc.mask};
    };
    std::fprintf(stderr, "train vbb: text encoder %s (token width %lld)\n", tpath.c_str(), (long long)text_dim);
  }

  fs::create_directories(out);
  tb::VbbTrainer tr(a.cfg, train, a.cfg.loss.lambda_pi > 0 ? agent.get() : nullptr, text, text_dim);
  if (a.resume && fs::exists(state)) {
    tr.load(state);
    std::fprintf(stderr, "train vbb: resumed %s at step %lld\n", state.c_str(), (long long)tr.steps_done());
  }
  const int64_t stop = a.stop_at > 0 ? std::min(a.stop_at, a.cfg.steps) : a.cfg.steps;
  t2m::nn::TrainLog log(out + "/log.jsonl", tr.steps_done());
  t2m::nn::ProgressOptions po;
  po.start = tr.steps_done();
  t2m::nn::Progress bar(a.cfg.steps, "train vbb", po);
  const auto run_start = clock_type::now();
  const int64_t first = tr.steps_done();
  while (tr.steps_done() < stop) {
    const tb::VbbStepStats s = tr.step();
    const int64_t step = tr.steps_done();
    json rec = {{"step", step}, {"loss", s.total}, {"latent_mse", s.latent_mse}, {"action_kl", s.action_kl},
                {"kl", s.kl},   {"sem", s.sem},    {"grad_norm", s.grad_norm},   {"lr", s.lr}};
    if (a.eval_every > 0 && step % a.eval_every == 0) {
      const auto v = tb::evaluate_vbb(tr.model(), val, a.cfg.window, agent.get());
      rec["val_latent_mse"] = v.latent_mse;
      rec["val_action_kl"] = v.action_kl;
    }
    if (step % a.log_every == 0 || step == stop || rec.contains("val_latent_mse")) log.write(rec);
    bar.update(step, {{"loss", s.total}, {"mse", s.latent_mse}, {"akl", s.action_kl}, {"sem", s.sem}});
    if (step % a.save_every == 0 || step == stop) tr.save(state);
  }
  bar.finish();
  if (tr.steps_done() == first) tr.save(state);
  const double secs = std::chrono::duration<double>(clock_type::now() - run_start).count();
  try {
    t2m::nn::SvgPlotOptions so;
    so.keys = {"loss", "latent_mse", "action_kl", "sem", "val_latent_mse", "val_action_kl"};
    so.log_y = true;
    so.title = "t2m train vbb: losses (Bandai-Namco train split; val = our val split)";
    t2m::nn::write_loss_svg(out + "/log.jsonl", out + "/loss.svg", so);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "train vbb: no loss plot (%s)\n", e.what());
  }
  std::printf("train vbb: %lld steps this run in %.1f s (%.2f steps/s), at %lld / %lld; state %s\n",
              (long long)(tr.steps_done() - first), secs, (tr.steps_done() - first) / std::max(secs, 1e-9),
              (long long)tr.steps_done(), (long long)a.cfg.steps, state.c_str());
  if (tr.steps_done() < a.cfg.steps) return;  // a chunk: scores and the checkpoint come with the last one

  const auto rv = tb::evaluate_vbb(tr.model(), val, a.cfg.window, agent.get());
  const auto rt = tb::evaluate_vbb(tr.model(), test, a.cfg.window, agent.get());
  const auto rvs = tb::evaluate_vbb(tr.model(), val, a.cfg.window, agent.get(), 64, true);
  const auto rts = tb::evaluate_vbb(tr.model(), test, a.cfg.window, agent.get(), 64, true);
  const json info = {{"command", cmdline},
                     {"steps", tr.steps_done()},
                     {"bfm", bfm_path},
                     {"bfm_checksum", checksum},
                     {"train_config", a.cfg.to_json()},
                     {"data", "Bandai-Namco-Research-Motiondataset (CC BY-NC 4.0), train split; scores on our "
                              "val/test splits"},
                     {"val", rv.to_json()},
                     {"test", rt.to_json()},
                     {"val_sphere", rvs.to_json()},
                     {"test_sphere", rts.to_json()}};
  const std::string ckpt = out + "/vbb.t2mckpt";
  tb::save_vbb(tr.model(), ckpt, info);
  json summary = info;
  summary["seconds_last_chunk"] = secs;
  summary["seconds_total_wall_last_chunk"] = std::chrono::duration<double>(clock_type::now() - t_start).count();
  t2m::nn::write_file_atomic(out + "/summary.json", summary.dump(1) + "\n");
  if (!a.ship.empty()) t2m::cli::copy_file_atomic(ckpt, a.ship);
  std::printf("vbb (compression %lld, lambda_sem %g): checkpoint %s%s%s\n", (long long)a.compression,
              a.cfg.loss.lambda_sem, ckpt.c_str(), a.ship.empty() ? "" : ", shipped to ", a.ship.c_str());
  print_row("val", rv);
  print_row("test", rt);
  print_row("val", rvs, ", Proj to the sphere");
  print_row("test", rts, ", Proj to the sphere");
}

void add_train_vbb(CLI::App& app) {
  auto* g = t2m::cli::command_group(app, "train", "train a model");
  auto* c = g->add_subcommand("vbb", "train the VBB (Text2BFM Eq 13) on cached BFM latents of the train split");
  static TrainVbbArgs a;
  auto& cfg = a.cfg;
  cfg.vbb.width = 128;  // the small CPU config (docs/VBB.md); the paper's is --width 256 --depth 3
  cfg.vbb.depth = 2;
  c->add_option("--out", a.out, "run directory (default ~/.cache/t2m/vbb/default)");
  c->add_option("--bfm", a.bfm, "BFM policy checkpoint (default models/checkpoints/bfm_stand.t2mckpt)");
  c->add_option("--text", a.text, "text encoder checkpoint (default models/checkpoints/text_encoder.t2mckpt)");
  c->add_option("--latents", a.latents, "latent cache directory (default ~/.cache/t2m/latents)");
  c->add_option("--manifest", a.manifest, "data manifest (default ~/.cache/t2m/bandai/manifest.json)");
  c->add_option("--ship", a.ship, "copy the final checkpoint here (e.g. models/checkpoints/vbb_small.t2mckpt)");
  c->add_flag("--resume", a.resume, "continue from DIR/train_state.t2mckpt");
  c->add_flag("--avg-pool", a.avg_pool, "score the average-pooling baseline on val/test instead of training");
  c->add_option("--export-pool", a.export_pool, "with --avg-pool: write the pooling bottleneck as a VBB checkpoint");
  c->add_option("--score", a.score, "score this VBB checkpoint on val/test (raw and projected) instead of training");
  c->add_option("--stop-at", a.stop_at, "stop (resumably) after this many steps in total");
  c->add_option("--steps", cfg.steps, "optimizer steps of the whole run")->capture_default_str();
  c->add_option("--batch", cfg.batch, "windows per batch")->capture_default_str();
  c->add_option("--window", cfg.window, "latent frames per window (multiple of the compression)")->capture_default_str();
  c->add_option("--lr", cfg.lr, "peak learning rate (paper 5e-5; higher for short CPU runs)")->capture_default_str();
  c->add_option("--weight-decay", cfg.weight_decay, "AdamW weight decay")->capture_default_str();
  c->add_option("--warmup", cfg.warmup, "linear warm-up steps")->capture_default_str();
  c->add_option("--seed", cfg.seed, "seed (init, batches, dropout, eps)")->capture_default_str();
  c->add_option("--compression", a.compression, "1 (no compression), 4, 8 or 16")->capture_default_str();
  c->add_option("--width", cfg.vbb.width, "conv width")->capture_default_str();
  c->add_option("--depth", cfg.vbb.depth, "residual blocks per level")->capture_default_str();
  c->add_flag("--pool-init", cfg.pool_init, "start at average pooling (needs --latent = the BFM's z_dim; ours)");
  c->add_option("--dropout", cfg.vbb.dropout, "residual dropout")->capture_default_str();
  c->add_option("--latent", cfg.vbb.latent, "program channels")->capture_default_str();
  c->add_option("--lambda-pi", cfg.loss.lambda_pi, "Eq 5 action-KL weight")->capture_default_str();
  c->add_option("--beta", cfg.loss.beta, "Eq 13 prior-KL weight")->capture_default_str();
  c->add_option("--lambda-sem", cfg.loss.lambda_sem, "Eq 13 semantic weight (0 = VBB without L_sem)")
      ->capture_default_str();
  c->add_option("--sem-dim", cfg.sem_dim, "semantic head width")->capture_default_str();
  c->add_option("--save-every", a.save_every, "steps between checkpoints")->capture_default_str();
  c->add_option("--log-every", a.log_every, "steps between log lines")->capture_default_str();
  c->add_option("--eval-every", a.eval_every, "steps between val scores in the log (0 = only at the end)");
  c->add_option("--threads", a.threads, "threads (0 = default); results are deterministic per thread count");
  c->callback([c] {
    std::string cmd = "t2m train vbb";  // config_to_str gives "name=value" lines
    std::istringstream lines(c->config_to_str(false, false));
    for (std::string l; std::getline(lines, l);) {
      const auto eq = l.find('=');
      if (eq == std::string::npos) continue;
      std::string v = l.substr(eq + 1);
      if (v.size() >= 2 && v.front() == '"' && v.back() == '"') v = v.substr(1, v.size() - 2);
      cmd += " --" + l.substr(0, eq) + (v == "true" ? "" : " " + v);
    }
    run_train_vbb(a, cmd);
  });
}

}  // namespace

T2M_COMMAND(add_train_vbb);
