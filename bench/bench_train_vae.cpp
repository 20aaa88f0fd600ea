// bench_train_vae.cpp — one full training step of the anchor's vae config (shared/anchor/REFERENCE.md "vae",
// torch_ref.py vae_case): zero grad, forward (train mode: dropout 0.1 on), loss MSE(rec, x) + 1e-4 KL, backward,
// AdamW (lr 2e-4, weight decay 0.01), on the VBB (models/text2bfm/vbb.h, in_dim 256, width 256, latent 48,
// 3 levels, depth 3, 6.83M parameters) for B in {32, 256} x T in {64, 128}.
// Counters: ms (wall clock per step), GFLOP/s (conv FLOPs counted as torch_ref counts them: 3 x the forward conv
// FLOPs per step, so the rates compare directly), cpu_ms (process CPU time per step over all threads: less
// sensitive to other processes holding a core), %peak (GFLOP/s against the measured peak_GFLOP/s).
// Run: build-NAME/bench_train_vae --benchmark_min_time=2   (threads: OMP_NUM_THREADS, default 2 on this VM).
#include <benchmark/benchmark.h>


#include "autograd/ops_elementwise.h"
#include "bench/lib/step_timer.h"
#include "models/text2bfm/vbb.h"
#include "models/text2bfm/vbb_loss.h"
#include "nn/loss_regression.h"
#include "nn/optim_adamw.h"
#include "tensor/parallel.h"
#include "tensor/rng.h"

using namespace t2m;
using namespace t2m::text2bfm;

namespace {

// Forward conv FLOPs of the anchor MotionVAE on (B, T, in_dim), as torch_ref's conv hook counts them
// (2 * out.numel() * Cin * K per conv); a training step counts 3x.
double vae_forward_flops(const VbbConfig& c, int64_t B, int64_t T) {
  auto conv = [&](int64_t cin, int64_t cout, int64_t k, int64_t tout) { return 2.0 * B * cout * tout * cin * k; };
  const int64_t C = c.width;
  double f = conv(c.in_dim, C, 3, T);
  int64_t t = T;
  for (int64_t l = 0; l < c.levels; ++l) {
    t /= 2;
    f += conv(C, C, 4, t) + (double)c.depth * (conv(C, C, 3, t) + conv(C, C, 1, t));
  }
  f += conv(C, 2 * c.latent, 3, t) + conv(c.latent, C, 3, t);
  for (int64_t l = 0; l < c.levels; ++l) {
    f += (double)c.depth * (conv(C, C, 3, t) + conv(C, C, 1, t));
    t *= 2;
    f += conv(C, C, 3, t);
  }
  return f + conv(C, C, 3, t) + conv(C, c.in_dim, 3, t);
}

void BM_train_vae(benchmark::State& st) {
  const int64_t B = st.range(0), T = st.range(1);
  VbbConfig cfg;
  cfg.in_dim = 256;
  Generator gen(1);
  Vbb vbb(cfg, gen);
  vbb.train();
  nn::AdamWOptions ao;
  ao.lr = 2e-4;
  ao.weight_decay = 0.01;
  nn::AdamW opt(vbb.named_parameters(), ao);
  ag::Variable x(rand_normal({B, T, cfg.in_dim}, gen));
  auto step = [&] {
    opt.zero_grad();
    VbbOutput o = vbb.forward(x, gen);
    ag::Variable loss = ag::add(nn::mse_loss(o.z_hat, x), ag::mul(vbb_prior_kl(o.mu, o.logvar), 1e-4));
    loss.backward();
    opt.step();
    return loss.item();
  };
  bench::time_steps(st, [&] { benchmark::DoNotOptimize(step()); }, 3.0 * vae_forward_flops(cfg, B, T));
  st.counters["params_M"] = (double)vbb.num_parameters() * 1e-6;
}

}  // namespace

BENCHMARK(BM_train_vae)
    ->Apply(bench::steps_from_env)
    ->ArgNames({"B", "T"})
    ->Args({32, 64})
    ->Args({256, 64})
    ->Args({32, 128})
    ->Args({256, 128})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

BENCHMARK_MAIN();
