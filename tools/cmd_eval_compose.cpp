// cmd_eval_compose.cpp — `t2m eval compose`: Table 2 of Text2BFM (§4.3) on prompts made from a split's clips:
// single-program Text2BFM vs Text2BFM-Compose, N clauses each, Order Accuracy, MM-Dist (segment vs its clause),
// Transition (Eq 20), with the frozen metric evaluator (models/text2bfm/compose_eval.h, models/eval/compositional.h).
//   t2m eval compose [--n 2 --n 3] [--prompts 50] [--seconds-per-clause 3] [--overlap 4] [--cfg 1.5] [--steps 0]
//                    [--split test] [--checkpoints D] [--gen CKPT] [--seed 0] [--threads T] [--out REPORT.json]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "models/eval/evaluator.h"
#include "models/text2bfm/compose_eval.h"
#include "nn/checkpoint.h"
#include "tensor/parallel.h"
#include "tools/command.h"
#include "tools/text_data.h"

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using t2m::Error;
namespace t2b = t2m::text2bfm;

struct Args {
  t2m::cli::TextDataOptions data;
  std::string split = "test", checkpoints = "models/checkpoints", gen, out;
  std::string evaluator = "models/checkpoints/evaluator.t2mckpt";
  std::vector<int64_t> ns{2, 3};
  int64_t prompts = 50;
  double seconds_per_clause = 3.0;
  t2b::ComposeEvalOptions opt = [] {
    t2b::ComposeEvalOptions o;
    o.gen.steps = 0;
    return o;
  }();
};

void run(Args a) {
  if (a.data.threads < 0) throw Error("eval compose: --threads must be >= 0");
  if (!(a.seconds_per_clause > 0)) throw Error("eval compose: --seconds-per-clause must be > 0");
  const int threads = a.data.threads > 0 ? a.data.threads : t2m::get_num_threads();
  auto paths = t2b::PipelinePaths::in_dir(a.checkpoints);
  if (!a.gen.empty()) paths.gen = a.gen;
  auto models = t2b::load_text2bfm(paths);
  if (a.opt.gen.steps == 0) a.opt.gen.steps = models.gen.objective == "diffusion" ? 50 : 16;
  a.opt.gen.validate();  // bad --cfg / --steps / --overlap / --candidates before any work
  a.opt.frames_per_clause = std::max<int64_t>(1, std::llround(a.seconds_per_clause * 30));
  a.opt.jobs = threads;
  if (!fs::exists(a.evaluator)) throw Error("eval compose: evaluator checkpoint '" + a.evaluator + "' not found");
  const auto ev = t2m::eval::load_evaluator(a.evaluator);
  const auto td = t2m::cli::load_text_data(a.data);
  auto clips = t2m::cli::split_clips(td, t2m::data::split_from_name(a.split), threads);
  std::sort(clips.begin(), clips.end(), [](const auto& x, const auto& y) { return x.name < y.name; });
  t2m::set_num_threads(1);  // one generation per thread

  json rows = json::array();
  std::printf("Compositional prompts from the %s split (Bandai-Namco, our captions), %lld per N, %.1f s per clause, "
              "%s, cfg %g, %lld steps, overlap %lld, %lld candidate(s)\n", a.split.c_str(), (long long)a.prompts,
              a.seconds_per_clause, models.gen.objective.c_str(), a.opt.gen.cfg, (long long)a.opt.gen.steps,
              (long long)a.opt.gen.overlap, (long long)a.opt.gen.candidates);
  std::printf("| Method | N | Order Acc. | MM-Dist | Transition | fell | wall s | CPU s |\n|---|---|---|---|---|---|---|---|\n");
  for (int64_t N : a.ns) {
    const auto prompts = t2b::make_compose_prompts(clips, N, a.prompts, a.opt.seed);
    {
      const auto r = t2b::evaluate_real_segments(ev, prompts, clips, a.opt.frames_per_clause);
      std::printf("| %s | %lld | %.3f | %.3f | – | – | – | – |\n", r.method.c_str(), (long long)N, r.order_accuracy,
                  r.mm_dist);
      rows.push_back({{"method", r.method}, {"N", N}, {"prompts", r.prompts}, {"order_accuracy", r.order_accuracy},
                      {"mm_dist", r.mm_dist}});
    }
    for (bool compose : {false, true}) {
      const auto r = t2b::evaluate_compose(models, ev, prompts, a.opt, compose);
      std::printf("| %s | %lld | %.3f | %.3f | %.3f | %lld/%lld | %.0f | %.0f |\n", r.method.c_str(), (long long)N,
                  r.order_accuracy, r.mm_dist, r.transition, (long long)r.fell, (long long)r.prompts, r.wall_s,
                  r.cpu_s);
      std::fflush(stdout);
      rows.push_back({{"method", r.method}, {"N", N}, {"prompts", r.prompts}, {"order_accuracy", r.order_accuracy},
                      {"mm_dist", r.mm_dist}, {"transition", r.transition}, {"fell", r.fell}, {"wall_s", r.wall_s},
                      {"cpu_s", r.cpu_s}, {"example_prompt", prompts[0].prompt}});
    }
  }
  const std::string out = a.out.empty() ? t2m::cli::default_output_dir("t2meval") + "/compose_" + a.split + ".json"
                                        : a.out;
  if (!fs::path(out).parent_path().empty()) fs::create_directories(fs::path(out).parent_path());
  const json j = {{"data", "Bandai-Namco-Research-Motiondataset 1+2 (CC BY-NC 4.0), " + a.split +
                             " split, captions from its labels (seed 7, index 0)"},
                  {"checkpoints", {{"gen", paths.gen}, {"vbb", paths.vbb}, {"bfm", paths.bfm}}},
                  {"evaluator", a.evaluator}, {"seconds_per_clause", a.seconds_per_clause},
                  {"cfg", a.opt.gen.cfg}, {"steps", a.opt.gen.steps}, {"overlap", a.opt.gen.overlap},
                  {"candidates", a.opt.gen.candidates}, {"seed", a.opt.seed}, {"threads", threads}, {"rows", rows}};
  t2m::nn::write_file_atomic(out, j.dump(1) + "\n");
  std::printf("report: %s\n", out.c_str());
}

void add_eval_compose(CLI::App& app) {
  auto* g = t2m::cli::command_group(app, "eval", "evaluate models and motions");
  auto a = std::make_shared<Args>();
  auto* c = g->add_subcommand("compose", "Table 2: Order Accuracy, MM-Dist, Transition (Eq 20), Text2BFM vs Compose");
  c->add_option("--n", a->ns, "clause counts N (repeatable)")->capture_default_str();
  c->add_option("--prompts", a->prompts, "prompts per N")->capture_default_str();
  c->add_option("--seconds-per-clause", a->seconds_per_clause, "length per clause")->capture_default_str();
  c->add_option("--overlap", a->opt.gen.overlap, "Compose: latents blended per boundary (Eq 19)")
      ->capture_default_str();
  c->add_option("--cfg", a->opt.gen.cfg, "classifier-free guidance weight")->capture_default_str();
  c->add_option("--steps", a->opt.gen.steps, "sampler steps (0: 16 flow / 50 diffusion)")->capture_default_str();
  c->add_option("--seed", a->opt.seed, "seed of the prompts and generations")->capture_default_str();
  c->add_option("--candidates", a->opt.gen.candidates, "programs tried per generation; the rollout upright longest "
                "is kept (as `t2m generate --candidates`)")->capture_default_str();
  c->add_option("--split", a->split, "split whose clips make the prompts")->capture_default_str();
  c->add_option("--checkpoints", a->checkpoints, "directory with the four .t2mckpt files")->capture_default_str();
  c->add_option("--gen", a->gen, "generator checkpoint (default CHECKPOINTS/gen_small.t2mckpt)");
  c->add_option("--evaluator", a->evaluator, "metric evaluator checkpoint")->capture_default_str();
  c->add_option("--out", a->out, "report (default ~/.cache/t2m/t2meval/compose_SPLIT.json)");
  c->add_option("--data", a->data.data_dir, "motion data directory");
  c->add_option("--cache", a->data.cache_dir, "cache directory");
  c->add_option("--threads", a->data.threads, "threads: generations run in parallel over prompts (0 = default)");
  c->callback([a] { run(*a); });
}

}  // namespace

T2M_COMMAND(add_eval_compose);
