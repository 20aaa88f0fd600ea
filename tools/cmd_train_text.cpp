// cmd_train_text.cpp — `t2m train text` (the generator-side TMR-style text/motion encoders) and `t2m train
// evaluator` (the GRU metric evaluator): contrastive training on the TRAIN split of the Bandai data, resumable
// (--resume), progress bar, JSONL log + SVG loss plot, a retrieval checkpoint and a summary.json with the val and
// test split R-precision. Output under ~/.cache/t2m/<text_encoder|evaluator>/ unless --out; --ship PATH also
// copies the checkpoint there (models/checkpoints/*.t2mckpt). See docs/TEXT.md.
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>

#include "models/data/features.h"
#include "models/eval/evaluator.h"
#include "models/text/caption_corpus.h"
#include "models/text/retrieval_train.h"
#include "models/text/text_motion_model.h"
#include "nn/checkpoint.h"
#include "tensor/parallel.h"
#include "tools/command.h"
#include "tools/text_data.h"

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using t2m::Error;

// Captions of the val/test scores: make_caption(content, style, kScoreCaptionSeed, 0) per clip.
constexpr uint64_t kScoreCaptionSeed = 7;

struct TrainArgs {
  t2m::cli::TextDataOptions data;
  std::string out, ship;
  bool resume = false;
  int window = 128;
  t2m::text::RetrievalTrainConfig cfg;
  // text_encoder
  t2m::text::TextMotionConfig tm;
  // evaluator
  t2m::eval::EvaluatorConfig ev;
};

void add_common(CLI::App* c, TrainArgs& a, const std::string& kind) {
  c->add_option("--data", a.data.data_dir, "motion data directory (default: $T2M_DATA or ../shared/data/bandai)");
  c->add_option("--cache", a.data.cache_dir, "cache directory (default: $T2M_CACHE or ~/.cache/t2m)");
  c->add_option("--out", a.out, "output directory (default: ~/.cache/t2m/" + kind + ")");
  c->add_option("--ship", a.ship,
                "also copy the final checkpoint to this path (e.g. models/checkpoints/" + kind + ".t2mckpt)");
  c->add_flag("--resume", a.resume, "continue from OUT/train_state.t2mckpt when it exists");
  c->add_option("--steps", a.cfg.steps, "optimizer steps")->capture_default_str()->check(CLI::PositiveNumber);
  c->add_option("--batch", a.cfg.batch, "batch size (pairs per InfoNCE batch)")->capture_default_str();
  c->add_option("--lr", a.cfg.lr, "peak learning rate (warm-up + cosine to lr/10)")->capture_default_str();
  c->add_option("--warmup", a.cfg.warmup, "warm-up steps")->capture_default_str();
  c->add_option("--seed", a.cfg.seed, "seed (init, batches, captions)")->capture_default_str();
  c->add_option("--window", a.window, "frames per training window (30 fps)")->capture_default_str();
  c->add_option("--save-every", a.cfg.save_every, "steps between resumable checkpoints")->capture_default_str();
  c->add_option("--eval-every", a.cfg.eval_every, "steps between val R-precision checks (0 = never)")
      ->capture_default_str();
  c->add_option("--stop-at", a.cfg.stop_at, "stop (resumably) after this many steps in total (0 = run to --steps)");
  c->add_option("--threads", a.data.threads, "threads (0 = default); results are deterministic per count");
}

void run_train(const TrainArgs& a, const std::string& kind,
               const std::function<std::shared_ptr<t2m::text::RetrievalModel>(int64_t vocab, t2m::Generator&)>& make,
               const std::string& cmdline) {
  if (a.data.threads > 0) t2m::set_num_threads(a.data.threads);
  if (a.window < 1) throw Error("train " + kind + ": --window must be >= 1");
  const std::string out = a.out.empty() ? t2m::cli::default_output_dir(kind) : a.out;
  fs::create_directories(out);
  const auto d = t2m::cli::load_text_data(a.data);
  std::fprintf(stderr, "train %s: loading the train/val/test clips ...\n", kind.c_str());
  const auto train = t2m::cli::split_clips(d, t2m::data::Split::train, a.data.threads);
  const auto val = t2m::cli::split_clips(d, t2m::data::Split::val, a.data.threads);
  const auto test = t2m::cli::split_clips(d, t2m::data::Split::test, a.data.threads);

  t2m::text::RetrievalBundle b;
  b.stats = t2m::data::clip_feature_stats(train, /*with_mirrors=*/true);
  t2m::text::CaptionCorpusOptions co;
  co.seed = a.cfg.seed;
  b.tokenizer = t2m::text::Tokenizer::build(t2m::text::split_caption_corpus(d.splits, t2m::data::Split::train, co));
  b.window = a.window;
  t2m::Generator g(a.cfg.seed);
  b.model = make(b.tokenizer.vocab_size(), g);
  std::fprintf(stderr, "train %s: %zu train / %zu val / %zu test clips, vocab %lld, %lld parameters\n", kind.c_str(),
               train.size(), val.size(), test.size(), (long long)b.tokenizer.vocab_size(),
               (long long)b.model->num_parameters());

  t2m::text::RetrievalTrainPaths p{out + "/train_state.t2mckpt", out + "/log.jsonl", out + "/loss.svg"};
  const auto r = t2m::text::train_retrieval(b, train, val, a.cfg, p, a.resume, "train " + kind);
  b.train = {{"command", cmdline},
             {"seed", a.cfg.seed},
             {"steps", r.steps},
             {"config", a.cfg.to_json()},
             {"data", "Bandai-Namco-Research-Motiondataset (CC BY-NC 4.0), train split"}};
  const std::string ckpt = out + "/" + kind + ".t2mckpt";
  t2m::text::save_retrieval_checkpoint(b, ckpt);

  std::fprintf(stderr, "train %s: scoring the val and test splits ...\n", kind.c_str());
  const auto sv = t2m::text::retrieval_r_precision(b, val, kScoreCaptionSeed);
  const auto st = t2m::text::retrieval_r_precision(b, test, kScoreCaptionSeed);
  json summary = {{"kind", kind},
                  {"checkpoint", ckpt},
                  {"steps", r.steps},
                  {"seconds_this_run", r.seconds},
                  {"final_loss_smoothed", r.final_loss},
                  {"parameters", b.model->num_parameters()},
                  {"vocab", b.tokenizer.vocab_size()},
                  {"data",
                   "Bandai-Namco-Research-Motiondataset (CC BY-NC 4.0); R-precision in batches of 32, "
                   "20 runs, mean and 95% CI; captions make_caption(labels, seed 7, index 0)"},
                  {"val", sv.to_json()},
                  {"test", st.to_json()},
                  {"train", b.train}};
  t2m::nn::write_file_atomic(out + "/summary.json", summary.dump(1) + "\n");
  if (!a.ship.empty()) t2m::cli::copy_file_atomic(ckpt, a.ship);
  std::printf("%s: %lld steps, loss %.4f; checkpoint %s%s%s\n", kind.c_str(), (long long)r.steps, r.final_loss,
              ckpt.c_str(), a.ship.empty() ? "" : ", shipped to ", a.ship.c_str());
  for (const auto& [name, s] : {std::pair{"val", &sv}, std::pair{"test", &st}})
    std::printf(
        "  %s split (%lld clips): R-precision top-1 %.3f +- %.3f, top-2 %.3f, top-3 %.3f +- %.3f; "
        "shuffled control top-3 %.3f (chance 3/32 = 0.094)\n",
        name, (long long)s->clips, s->top[0].mean, s->top[0].ci95, s->top[1].mean, s->top[2].mean, s->top[2].ci95,
        s->control[2].mean);
  std::printf("  log %s, plot %s, summary %s/summary.json\n", p.log.c_str(), p.svg.c_str(), out.c_str());
}

// "steps=800\nthreads=1\n" (CLI11 config form) -> " --steps 800 --threads 1".
std::string as_flags(const std::string& config) {
  std::string out, line;
  for (char ch : config + "\n") {
    if (ch != '\n') {
      line += ch;
      continue;
    }
    const size_t eq = line.find('=');
    if (!line.empty()) {
      out.append(" --").append(line.substr(0, eq));
      if (eq != std::string::npos) out.append(" ").append(line.substr(eq + 1));
    }
    line.clear();
  }
  return out;
}

void add_train_text(CLI::App& app) {
  auto* g = t2m::cli::command_group(app, "train", "train a model");
  {
    auto a = std::make_shared<TrainArgs>();
    a->cfg.seed = 1;
    a->cfg.steps = 600;
    a->tm.text.mlp_ratio = 2;  // small shipped checkpoint: ~1.8M parameters (7 MB)
    a->tm.motion.dim = 128;
    auto* c = g->add_subcommand("text", "train the text encoder + motion encoder (TMR-style InfoNCE, train split)");
    add_common(c, *a, "text_encoder");
    c->add_option("--dim", a->tm.text.dim, "text token feature width (y_{j,k})")->capture_default_str();
    c->add_option("--layers", a->tm.text.layers, "text transformer layers")->capture_default_str();
    c->add_option("--mlp-ratio", a->tm.text.mlp_ratio, "text transformer MLP width / dim")->capture_default_str();
    c->add_option("--heads", a->tm.text.heads, "attention heads (text and motion)")->capture_default_str();
    c->add_option("--motion-dim", a->tm.motion.dim, "motion transformer width")->capture_default_str();
    c->add_option("--motion-layers", a->tm.motion.layers, "motion transformer layers")->capture_default_str();
    c->add_option("--embed-dim", a->tm.text.embed_dim, "joint embedding width")->capture_default_str();
    c->callback([a, c] {
      a->tm.motion.heads = a->tm.text.heads;
      a->tm.motion.embed_dim = a->tm.text.embed_dim;
      a->tm.motion.feature_dim = t2m::data::kFeatureDim;
      a->tm.motion.max_patches = (a->window + a->tm.motion.patch - 1) / a->tm.motion.patch;
      run_train(
          *a, "text_encoder",
          [a](int64_t vocab, t2m::Generator& gen) {
            t2m::text::TextMotionConfig cfg = a->tm;
            cfg.text.vocab = vocab;
            return std::make_shared<t2m::text::TextMotionModel>(cfg, gen);
          },
          "t2m train text" + as_flags(c->config_to_str(false, false)));
    });
  }
  {
    auto a = std::make_shared<TrainArgs>();
    a->cfg.seed = 2;
    a->cfg.steps = 800;
    a->cfg.lr = 1e-3;
    auto* c = g->add_subcommand("evaluator", "train the GRU metric evaluator (InfoNCE, train split, seed 2)");
    add_common(c, *a, "evaluator");
    c->add_option("--word-dim", a->ev.word_dim, "word embedding width")->capture_default_str();
    c->add_option("--text-hidden", a->ev.text_hidden, "text GRU hidden size")->capture_default_str();
    c->add_option("--motion-hidden", a->ev.motion_hidden, "motion GRU hidden size")->capture_default_str();
    c->add_option("--embed-dim", a->ev.embed_dim, "joint embedding width")->capture_default_str();
    c->callback([a, c] {
      a->ev.feature_dim = t2m::data::kFeatureDim;
      a->ev.max_frames = a->window;
      run_train(
          *a, "evaluator",
          [a](int64_t vocab, t2m::Generator& gen) {
            t2m::eval::EvaluatorConfig cfg = a->ev;
            cfg.vocab = vocab;
            return std::make_shared<t2m::eval::Evaluator>(cfg, gen);
          },
          "t2m train evaluator" + as_flags(c->config_to_str(false, false)));
    });
  }
}

}  // namespace

T2M_COMMAND(add_train_text);
