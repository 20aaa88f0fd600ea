// bench_train_fb.cpp — one FB agent training update (models/bfm/fb_agent.h) at the anchor's fb configs
// (../shared/anchor/REFERENCE.md: obs 358, action 69, z 256, B width 256; F/actor width h), the same work per
// step as torch_ref.py's fb_case: z sampled as there (half B(s') of a permuted batch, half random sphere points,
// no grad), then the part: "fb" (FB loss with targets, backward, AdamW on F and B, Polyak), "actor" (actor loss,
// backward, AdamW on the actor; we skip F's parameter gradients, which the anchor computes and discards), or
// "both" (one full update()).
// Counters: ms (wall clock per step), cpu_ms (process CPU time per step, all threads: less sensitive to other
// load on the machine), GFLOP/s with the anchor's FLOP count (Linear and bmm FLOPs, x3 under grad), %peak
// against this machine's measured FMA peak x threads (bench::peak_gflops_per_core()). Threads: OMP_NUM_THREADS /
// t2m::get_num_threads().
// Usage: build-X/bench_train_fb [--benchmark_filter=w256] [--benchmark_format=json]
#include <benchmark/benchmark.h>

#include <cmath>
#include <string>

#include "bench/lib/step_timer.h"
#include "models/bfm/fb_agent.h"
#include "tensor/ops.h"
#include "tensor/parallel.h"
#include "tensor/rng.h"

namespace {

using namespace t2m;

constexpr int kObs = 358, kAct = 69, kZ = 256, kBHidden = 256;

enum Part { kFb = 0, kActor = 1, kBoth = 2 };
const char* part_name(int p) { return p == kFb ? "fb" : p == kActor ? "actor" : "both"; }

// The anchor's FLOP count (torch_ref.py FlopCounter): forward Linear/bmm FLOPs, x3 when grad is enabled.
double step_flops(double h, double N, int part) {
  const double D = kObs, A = kAct, d = kZ, bh = kBHidden;
  auto emb = [&](double in) { return 2 * N * (in * h + h * h / 2); };
  const double Fm = emb(D + d) + emb(D + A) + 2 * N * (h * h + h * d);
  const double Bm = 2 * N * (D * bh + bh * bh + bh * d);
  const double Am = emb(D + d) + emb(D) + 2 * N * (h * h + h * A);
  const double bmm = 2 * 2 * N * N * d;  // 2 members, [N, d] x [d, N]
  double f = Bm;                          // sample_z: B(s') under no grad
  if (part != kActor) f += Am + 2 * Fm + Bm + bmm + 3 * (2 * Fm + Bm + bmm + 2 * N * N * d);
  if (part != kFb) f += 3 * (Am + 2 * Fm);
  return f;
}

// The anchor's sample_z: where(rand < 0.5, B(next_obs[randperm]), sqrt(d) normalize(randn)).
Tensor sample_z(bfm::FbAgent& agent, const Tensor& next_obs, Generator& gen) {
  const int64_t N = next_obs.size(0);
  const std::vector<int64_t> perm = randperm(N, gen);
  const Tensor zb = agent.embed_backward(index_select(next_obs, 0, Tensor::from_vector(perm, {N})));
  const Tensor zs = agent.sample_sphere_z((int)N, gen);
  const Tensor mask = lt(rand_uniform({N, 1}, gen), 0.5);
  return where(mask, zb, zs);
}

void BM_train_fb(benchmark::State& st, int width, int batch, int part) {
  bfm::FbConfig c;
  c.obs_dim = kObs;
  c.action_dim = kAct;
  c.z_dim = kZ;
  c.hidden = width;
  c.b_hidden = kBHidden;
  c.bc_coef = 0;           // the anchor's objectives
  c.q_normalize = false;
  bfm::FbAgent agent(c, 0);
  Generator gen(1);
  bfm::FbBatch b;
  b.obs = rand_normal({batch, kObs}, gen);
  b.next_obs = rand_normal({batch, kObs}, gen);
  b.action = rand_uniform({batch, kAct}, gen, -1, 1);
  b.not_done = Tensor::ones({batch});
  auto step = [&] {
    b.z = sample_z(agent, b.next_obs, gen);
    if (part == kFb) agent.update_fb(b, gen);
    else if (part == kActor) agent.update_actor(b, gen);
    else agent.update(b, gen);
  };
  bench::time_steps(st, step, step_flops(width, batch, part), /*warmup=*/2);  // 2: the allocator's caches fill
}

}  // namespace

int main(int argc, char** argv) {
  for (auto [w, n] : {std::pair{256, 256}, std::pair{1024, 1024}})
    for (int part : {kFb, kActor, kBoth}) {
      const std::string name =
          "fb-w" + std::to_string(w) + " B" + std::to_string(n) + " " + part_name(part);
      auto* b = benchmark::RegisterBenchmark(name.c_str(), BM_train_fb, w, n, part)
                    ->Unit(benchmark::kMillisecond)
                    ->UseRealTime();
      if (bench::fixed_steps())
        bench::steps_from_env(b);
      else
        b->MinTime(w >= 1024 ? 3.0 : 1.0);
    }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
