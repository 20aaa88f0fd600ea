// bench_generate.cpp — latency of text -> 10 s simulated clip (models/text2bfm/pipeline.h generate_motion: 300
// control steps, physics included, no files, no render), per stage: text (tokenizer + frozen text encoder),
// sample (16 Euler steps, CFG 1.5, conditional + null pass batched), decode (VBB D_θ + sphere projection),
// rollout (BFM policy mean + 15 MuJoCo substeps per control step).
// Models: the four checkpoints of $T2M_CHECKPOINTS (default models/checkpoints) when they all exist; otherwise
// random weights at the shipped sizes (text encoder from its checkpoint when present; VBB VbbConfig defaults;
// generator = `t2m train gen` defaults; BFM FbConfig defaults). Latency does not depend on the weights except
// through the physics (a fallen body has other contacts), so the random-weight numbers are labelled as such.
// Counters: ms per stage (wall), cpu_*_ms per stage (process CPU time, all threads: the cost when other
// processes share the cores), peak RSS (MB).
// Run: OMP_NUM_THREADS=2 OMP_WAIT_POLICY=passive build-NAME/bench_generate --benchmark_min_time=3
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "models/bfm/fb_agent.h"
#include "models/data/features.h"
#include "models/text/text_motion_model.h"
#include "models/text2bfm/pipeline.h"

using namespace t2m;
using namespace t2m::text2bfm;
namespace fs = std::filesystem;

namespace {

double rss_mb() {
  std::ifstream f("/proc/self/status");
  std::string k;
  while (f >> k)
    if (k == "VmHWM:") {
      double kb = 0;
      f >> kb;
      return kb / 1024.0;
    }
  return 0;
}

Text2BfmModels& models(bool* random_weights) {
  static std::unique_ptr<Text2BfmModels> m;
  static bool random = false;
  if (!m) {
    const char* env = std::getenv("T2M_CHECKPOINTS");
    const auto p = PipelinePaths::in_dir(env ? env : "models/checkpoints");
    if (fs::exists(p.text) && fs::exists(p.vbb) && fs::exists(p.gen) && fs::exists(p.bfm)) {
      m = std::make_unique<Text2BfmModels>(load_text2bfm(p));
    } else {
      random = true;
      m = std::make_unique<Text2BfmModels>();
      Generator g(0);
      if (fs::exists(p.text)) {
        m->text = text::load_text_motion_model(p.text);
      } else {
        text::TextMotionConfig c;
        m->text.tokenizer = text::Tokenizer::build({"a person walks forward then waves"});
        c.text.vocab = m->text.tokenizer.vocab_size(), c.text.mlp_ratio = 2, c.motion.dim = 128;
        m->text.model = std::make_shared<text::TextMotionModel>(c, g);
      }
      m->encoder = &dynamic_cast<const text::TextMotionModel&>(*m->text.model).text();
      m->vbb = std::make_shared<Vbb>(VbbConfig{}, g);
      m->vbb->eval();
      FlowGeneratorConfig fc = FlowGeneratorConfig::small();  // `t2m train gen` defaults
      fc.width = 128, fc.ctx_dim = 128, fc.adapter.width = 128, fc.adapter.ctx_dim = 128;
      fc.latent = m->vbb->config().latent;
      fc.adapter.tok_dim = m->encoder->config().dim, fc.adapter.max_len = m->encoder->config().max_len;
      m->gen.model = std::make_shared<FlowGenerator>(fc, g);
      m->gen.model->eval();
      m->gen.program_mean = Tensor::zeros({fc.latent});
      m->gen.program_std = Tensor::ones({fc.latent});
      m->gen.compression = m->vbb->config().compression();
      m->policy = std::make_unique<bfm::FbAgent>(bfm::FbConfig{}, 0);
      m->humanoid = sim::Humanoid::create();
    }
  }
  *random_weights = random;
  return *m;
}

void BM_generate_10s(benchmark::State& st) {
  bool random = false;
  Text2BfmModels& m = models(&random);
  GenerateOptions o;
  o.length_s = 10.0;
  StageTimes sum, cpu;
  int64_t n = 0;
  for (auto _ : st) {
    o.seed = (uint64_t)n;
    const Generation g = generate_motion(m, "a person walks forward, then waves with the right hand", o);
    sum.text += g.times.text, sum.sample += g.times.sample, sum.decode += g.times.decode;
    sum.rollout += g.times.rollout;
    cpu.text += g.cpu.text, cpu.sample += g.cpu.sample, cpu.decode += g.cpu.decode, cpu.rollout += g.cpu.rollout;
    ++n;
  }
  st.counters["text_ms"] = 1e3 * sum.text / n;
  st.counters["sample_ms"] = 1e3 * sum.sample / n;
  st.counters["decode_ms"] = 1e3 * sum.decode / n;
  st.counters["rollout_ms"] = 1e3 * sum.rollout / n;
  st.counters["total_ms"] = 1e3 * (sum.text + sum.sample + sum.decode + sum.rollout) / n;
  st.counters["cpu_text_ms"] = 1e3 * cpu.text / n;
  st.counters["cpu_sample_ms"] = 1e3 * cpu.sample / n;
  st.counters["cpu_decode_ms"] = 1e3 * cpu.decode / n;
  st.counters["cpu_rollout_ms"] = 1e3 * cpu.rollout / n;
  st.counters["peak_rss_MB"] = rss_mb();
  st.SetLabel(random ? "random weights at shipped sizes" : "shipped checkpoints");
}
BENCHMARK(BM_generate_10s)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
