// cmd_generate.cpp — `t2m generate "PROMPT" --out DIR` (text -> simulated motion, models/text2bfm/pipeline.h) and
// `t2m compose "A, then B" --out DIR` (the same with one program per clause, Eq 18-19; = generate --compose).
// Checkpoints from --checkpoints DIR (default models/checkpoints): text_encoder, vbb_small, gen_small, bfm_stand
// (text2bfm::PipelinePaths).
// DIR receives motion.bvh, render.mp4 (unless --no-render), states.bin and metrics.json, all or nothing.
// `--model NAME` runs a registered kinematic baseline instead (tools/kinematic_models.h; an unknown name lists
// them): DIR then receives features.npy, motion.bvh, render.mp4 and metrics.json (models/io/kinematic_output.h).
#include <time.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "models/io/kinematic_output.h"
#include "models/text/tokenizer.h"
#include "models/text2bfm/pipeline.h"
#include "tensor/parallel.h"
#include "tools/command.h"
#include "tools/kinematic_models.h"

namespace {

using t2m::Error;

struct GenerateArgs {
  std::string prompt, out, checkpoints = "models/checkpoints";
  t2m::text2bfm::GenerateOptions opt;
  std::string model = "text2bfm";
  std::string gen;  // generator checkpoint override (e.g. the diffusion variant); "" = CHECKPOINTS/gen_small
  bool no_render = false, overwrite = false;
  int threads = 0;
  CLI::Option *length_opt = nullptr, *cfg_opt = nullptr, *steps_opt = nullptr;
};

void add_options(CLI::App* c, GenerateArgs& a) {
  c->add_option("prompt", a.prompt, "the text prompt")->required();
  c->add_option("--out", a.out, "output directory (must not exist or be empty, unless --overwrite)")->required();
  c->add_option("--checkpoints", a.checkpoints, "directory with the four .t2mckpt files")->capture_default_str();
  c->add_option("--seed", a.opt.seed, "seed of m(0) ~ N(0, I)")->capture_default_str();
  a.length_opt = c->add_option("--length", a.opt.length_s, "clip length in seconds (30 control steps per second)")
                     ->capture_default_str();
  a.cfg_opt = c->add_option("--cfg", a.opt.cfg, "classifier-free guidance weight w")->capture_default_str();
  a.steps_opt = c->add_option("--steps", a.opt.steps, "Euler steps of the flow ODE (Eq 16)")->capture_default_str();
  c->add_option("--model", a.model, "text2bfm, or a kinematic baseline (an unknown name lists them)")
      ->capture_default_str();
  c->add_option("--overlap", a.opt.overlap, "compose: latent steps blended per clause boundary (Eq 19)")
      ->capture_default_str();
  c->add_option("--candidates", a.opt.candidates, "programs tried (seeds SEED .. SEED + K - 1, each rolled out); the "
                "rollout upright longest is kept (ours, not in the paper)")->capture_default_str();
  c->add_flag("--no-render", a.no_render, "skip render.mp4");
  c->add_flag("--overwrite", a.overwrite, "replace an existing output directory");
  c->add_option("--threads", a.threads, "threads (0 = default)");
  c->add_option("--gen", a.gen, "generator checkpoint (default CHECKPOINTS/gen_small.t2mckpt; a diffusion one, "
                "e.g. models/checkpoints/gen_diffusion_small.t2mckpt, is sampled with 50 DDIM steps)");
}

double process_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// A kinematic baseline: the registered model generates features, DIR gets features.npy/BVH/MP4/metrics.
void run_kinematic(const GenerateArgs& a) {
  const auto& model = t2m::cli::find_kinematic_model(a.model);
  if (a.opt.compose) throw Error("generate: --compose applies to --model text2bfm only");
  if (a.opt.candidates != 1) throw Error("generate: --candidates applies to --model text2bfm only");
  t2m::cli::KinematicRequest r;
  r.prompt = a.prompt;
  r.checkpoints = a.checkpoints;
  r.seed = a.opt.seed;
  if (a.length_opt->count()) {
    if (!(a.opt.length_s > 0 && a.opt.length_s <= 120)) throw Error("generate: --length must be in (0, 120] s");
    r.length_s = a.opt.length_s;
  }
  if (a.cfg_opt->count()) {
    if (!std::isfinite(a.opt.cfg) || a.opt.cfg < 0) throw Error("generate: --cfg must be finite and >= 0");
    r.cfg = a.opt.cfg;
  }
  if (a.steps_opt->count()) {
    if (a.opt.steps < 1) throw Error("generate: --steps must be >= 1");
    r.steps = a.opt.steps;
  }
  t2m::io::KinematicOutput g;
  g.prompt = a.prompt;
  g.model = model.name;
  const auto t0 = std::chrono::steady_clock::now();
  const double c0 = process_cpu_seconds();
  auto res = model.generate(r);
  g.generate_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  g.generate_cpu_s = process_cpu_seconds() - c0;
  g.features = std::move(res.features);
  g.info = std::move(res.info);
  t2m::io::KinematicWriteOptions w;
  w.render = !a.no_render;
  w.overwrite = a.overwrite;
  const auto metrics = t2m::io::write_kinematic_generation(g, t2m::sim::Humanoid::create(), a.out, w);
  std::printf("%s: model %s, %.2f s (%d frames), generated in %.3f s (%.3f s CPU, %d threads)\n", a.out.c_str(),
              model.name.c_str(), metrics["duration_s"].get<double>(), metrics["frames"].get<int>(), g.generate_s,
              g.generate_cpu_s, t2m::get_num_threads());
  std::printf("  %s/features.npy  %s/motion.bvh%s  %s/metrics.json\n", a.out.c_str(), a.out.c_str(),
              a.no_render ? "" : ("  " + a.out + "/render.mp4").c_str(), a.out.c_str());
}

void run(const GenerateArgs& a) {
  if (a.threads < 0) throw Error("generate: --threads must be >= 0");
  if (a.threads > 0) t2m::set_num_threads(a.threads);
  if (t2m::text::split_words(a.prompt).empty()) throw Error("generate: the prompt is empty");
  if (a.model != "text2bfm") return run_kinematic(a);
  a.opt.validate();
  auto paths = t2m::text2bfm::PipelinePaths::in_dir(a.checkpoints);
  if (!a.gen.empty()) paths.gen = a.gen;
  auto models = t2m::text2bfm::load_text2bfm(paths);
  // A diffusion generator (objective in its checkpoint) is sampled with DDIM: 50 steps unless --steps is given.
  t2m::text2bfm::GenerateOptions opt = a.opt;
  if (models.gen.objective == "diffusion" && a.steps_opt->count() == 0) opt.steps = 50;
  for (const auto& w : models.warnings) std::fprintf(stderr, "generate: warning: %s\n", w.c_str());
  auto g = t2m::text2bfm::generate_motion(models, a.prompt, opt);
  t2m::text2bfm::WriteOptions w;
  w.render = !a.no_render;
  w.overwrite = a.overwrite;
  const auto metrics = t2m::text2bfm::write_generation(g, models, a.out, w);
  std::printf("%s: %zu clause(s), %.2f s (%d frames), falls %d\n", a.out.c_str(), g.clauses.size(),
              metrics["duration_s"].get<double>(), g.traj.frames, g.falls);
  const auto& t = g.times;
  std::printf("  cpu (s): text %.4f  sample %.4f  decode %.4f  rollout %.4f\n", g.cpu.text, g.cpu.sample,
              g.cpu.decode, g.cpu.rollout);
  std::printf("  timing (s, %d threads): text %.4f  sample %.4f  decode %.4f  rollout %.4f  export %.4f  "
              "render %.4f\n",
              t2m::get_num_threads(), t.text, t.sample, t.decode, t.rollout, t.exporting, t.render);
  std::printf("  %s/motion.bvh%s  %s/states.bin  %s/metrics.json\n", a.out.c_str(),
              a.no_render ? "" : ("  " + a.out + "/render.mp4").c_str(), a.out.c_str(), a.out.c_str());
}

void add_generate(CLI::App& app) {
  {
    auto a = std::make_shared<GenerateArgs>();
    auto* c = app.add_subcommand("generate", "text -> Text2BFM program -> BFM rollout in MuJoCo -> BVH/MP4/JSON");
    add_options(c, *a);
    c->add_flag("--compose", a->opt.compose, "one program per clause (\"then\", \"after that\", commas)");
    c->callback([a] { run(*a); });
  }
  {
    auto a = std::make_shared<GenerateArgs>();
    a->opt.compose = true;
    auto* c = app.add_subcommand("compose", "Text2BFM-Compose: one program per clause, blended latents (Eq 18-19)");
    add_options(c, *a);
    c->callback([a] { run(*a); });
  }
}

}  // namespace

T2M_COMMAND(add_generate);
