// bench_fused.cpp — Google Benchmark for the fused kernels at the micro shapes of shared/anchor/REFERENCE.md
// (the same work as torch_ref.py's micro suite: forward + backward with input and parameter grads).
// Counters: ms (per iteration, wall clock), GFLOP/s (GEMM-style FLOPs, as torch_ref counts them) or GB/s
// (bytes a minimal fused implementation must move). Threads: OMP_NUM_THREADS / t2m::get_num_threads().
#include <benchmark/benchmark.h>

#include <chrono>
#include <random>
#include <vector>

#include "tensor/fused/adamw.h"
#include "tensor/fused/attention.h"
#include "tensor/fused/attention_ctx.h"
#include "tensor/fused/conv1d.h"
#include "tensor/fused/gelu_tanh.h"
#include "tensor/fused/group_norm.h"
#include "tensor/fused/layer_norm.h"
#include "tensor/parallel.h"

using namespace t2m::fused;

namespace {

std::vector<float> rand_vec(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> nd(0.0f, 1.0f);
  std::vector<float> v(n);
  for (auto& x : v) x = nd(rng);
  return v;
}

// Wall-clock timer around the timed loop: with UseRealTime the per-iteration time is what the table shows, and
// the counters below are derived from the same clock (plain values, no /s or s suffix games).
struct LoopTimer {
  std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
};

void set_counters(benchmark::State& st, const LoopTimer& timer, double flops, double bytes) {
  const double sec = timer.seconds(), it = (double)st.iterations();
  st.counters["ms"] = sec / it * 1e3;
  if (flops > 0) st.counters["GFLOP/s"] = flops * it / sec * 1e-9;
  if (bytes > 0) st.counters["GB/s"] = bytes * it / sec * 1e-9;
  st.counters["threads"] = t2m::get_num_threads();
}

// conv1d k3 padding 1 (nn.Conv1d(256, 256, 3, padding=1)), fwd + bwd (dinp, dweight, dbias).
void BM_conv1d_fwd_bwd(benchmark::State& st) {
  Conv1dShape s;
  s.B = st.range(0);
  s.Cin = s.Cout = 256;
  s.T = st.range(1);
  s.K = 3;
  s.pad = 1;
  const int64_t To = s.out_len();
  auto x = rand_vec(s.B * s.Cin * s.T, 1), w = rand_vec(s.Cout * s.Cin * s.K, 2), b = rand_vec(s.Cout, 3);
  auto dy = rand_vec(s.B * s.Cout * To, 4);
  std::vector<float> y(dy.size()), dx(x.size()), dw(w.size()), db(b.size());
  LoopTimer timer;
  for (auto _ : st) {
    conv1d_forward<float>(y.data(), x.data(), w.data(), b.data(), s);
    conv1d_backward<float>(dx.data(), dw.data(), db.data(), dy.data(), x.data(), w.data(), s);
    benchmark::DoNotOptimize(dx.data());
  }
  set_counters(st, timer, 3 * conv1d_forward_flops(s), 0);
}
BENCHMARK(BM_conv1d_fwd_bwd)->Args({32, 64})->Args({256, 32})->Unit(benchmark::kMillisecond)->UseRealTime();

// LayerNorm(512) on 4096 rows, fwd + bwd. Bytes: fwd reads x, writes y; bwd reads x, dy, writes dx.
void BM_layer_norm_fwd_bwd(benchmark::State& st) {
  const int64_t N = st.range(0), C = st.range(1);
  auto x = rand_vec(N * C, 5), w = rand_vec(C, 6), b = rand_vec(C, 7), dy = rand_vec(N * C, 8);
  std::vector<float> y(N * C), mean(N), rstd(N), dx(N * C), dw(C), db(C);
  LoopTimer timer;
  for (auto _ : st) {
    layer_norm_forward<float>(y.data(), mean.data(), rstd.data(), x.data(), w.data(), b.data(), N, C, 1e-5f);
    layer_norm_backward<float>(dx.data(), dw.data(), db.data(), dy.data(), x.data(), w.data(), mean.data(),
                               rstd.data(), N, C);
    benchmark::DoNotOptimize(dx.data());
  }
  set_counters(st, timer, 0, 5.0 * N * C * sizeof(float));
}
BENCHMARK(BM_layer_norm_fwd_bwd)->Args({4096, 512})->Unit(benchmark::kMillisecond)->UseRealTime();

// GroupNorm(32, 256) on (B, 256, T), fwd + bwd; relu 1: the fused GroupNorm -> ReLU of the VBB's residual blocks.
void BM_group_norm_fwd_bwd(benchmark::State& st) {
  const int64_t B = st.range(0), C = 256, T = st.range(1), G = 32, n = B * C * T;
  const bool relu = st.range(2) != 0;
  auto x = rand_vec(n, 9), w = rand_vec(C, 10), b = rand_vec(C, 11), dy = rand_vec(n, 12);
  std::vector<float> y(n), mean(B * G), rstd(B * G), dx(n), dw(C), db(C);
  LoopTimer timer;
  for (auto _ : st) {
    group_norm_forward<float>(y.data(), mean.data(), rstd.data(), x.data(), w.data(), b.data(), B, C, T, G, 1e-5f,
                              relu);
    group_norm_backward<float>(dx.data(), dw.data(), db.data(), dy.data(), x.data(), w.data(), mean.data(),
                               rstd.data(), B, C, T, G, relu, b.data());
    benchmark::DoNotOptimize(dx.data());
  }
  set_counters(st, timer, 0, 5.0 * n * sizeof(float));
}
BENCHMARK(BM_group_norm_fwd_bwd)
    ->ArgNames({"B", "T", "relu"})
    ->Args({32, 64, 0})
    ->Args({256, 32, 0})
    ->Args({256, 32, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// softmax attention, 64 (batch*heads) x T64 x d64, fwd + bwd (dq, dk, dv).
void BM_attention_fwd_bwd(benchmark::State& st) {
  AttentionShape s;
  s.B = 1;
  s.H = st.range(0);
  s.Tq = s.Tk = st.range(1);
  s.d = st.range(2);
  const int64_t n = s.B * s.H * s.Tq * s.d;
  auto q = rand_vec(n, 13), k = rand_vec(n, 14), v = rand_vec(n, 15), dout = rand_vec(n, 16);
  std::vector<float> out(n), att(s.B * s.H * s.Tq * s.Tk), dq(n), dk(n), dv(n);
  LoopTimer timer;
  for (auto _ : st) {
    attention_forward<float>(out.data(), att.data(), q.data(), k.data(), v.data(), nullptr, s);
    attention_backward<float>(dq.data(), dk.data(), dv.data(), dout.data(), att.data(), q.data(), k.data(),
                              v.data(), s);
    benchmark::DoNotOptimize(dq.data());
  }
  set_counters(st, timer, 3 * attention_forward_flops(s), 0);
}
BENCHMARK(BM_attention_fwd_bwd)->Args({64, 64, 64})->Unit(benchmark::kMillisecond)->UseRealTime();

// The fm-paper cross-attention's core in the value-after-sum form (attention_ctx.h): B x 8 heads of 64, Tq motion
// tokens over 24 text tokens of width 1024, QK RMS-norm; forward (P, U = P ctx), U recomputed, backward (dq, dk,
// dctx, norm weights). FLOPs: 2 per multiply-add of Q K^T, U = P ctx, and in the backward dP, dctx, dq, dk.
void BM_attention_ctx_fwd_bwd(benchmark::State& st) {
  AttentionHeads<float> a;
  a.s.B = st.range(0);
  a.s.H = 8;
  a.s.Tq = st.range(1);
  a.s.Tk = 24;
  a.s.d = 64;
  const int64_t B = a.s.B, H = a.s.H, Tq = a.s.Tq, Tk = a.s.Tk, d = a.s.d, C = 1024, D = H * d;
  auto q = rand_vec(B * Tq * D, 21), k = rand_vec(B * Tk * D, 22), ctx = rand_vec(B * Tk * C, 23);
  auto du = rand_vec(H * B * Tq * C, 24), qn = rand_vec(d, 25), kn = rand_vec(d, 26);
  a.q = q.data(), a.k = k.data(), a.ldq = a.ldk = D;
  a.q_norm = qn.data(), a.k_norm = kn.data(), a.norm_eps = 1e-6f;
  std::vector<float> u(H * B * Tq * C), att(B * H * Tq * Tk), rq(B * H * Tq), rk(B * H * Tk);
  std::vector<float> dq(q.size()), dk(k.size()), dctx(ctx.size()), dqn(d), dkn(d);
  LoopTimer timer;
  for (auto _ : st) {
    attention_ctx_forward<float>(u.data(), att.data(), rq.data(), rk.data(), a, ctx.data(), C);
    attention_ctx_values<float>(u.data(), att.data(), a.s, ctx.data(), C);
    attention_ctx_backward<float>(dq.data(), D, dk.data(), D, dctx.data(), dqn.data(), dkn.data(), du.data(),
                                  att.data(), rq.data(), rk.data(), a, ctx.data(), C);
    benchmark::DoNotOptimize(dctx.data());
  }
  const double qk = double(B * H * Tq * Tk * d), pc = double(B * H * Tq * Tk * C);
  set_counters(st, timer, 2 * (3 * qk + 4 * pc), 0);  // fwd: QK^T, U, U again; bwd: dP, dctx, dq, dk
}
BENCHMARK(BM_attention_ctx_fwd_bwd)->Args({32, 8})->Args({256, 8})->Unit(benchmark::kMillisecond)->UseRealTime();

// tanh-GELU on 4096 x 2048, fwd + bwd. Bytes: fwd reads x writes y; bwd reads x, dy, writes dx.
void BM_gelu_tanh_fwd_bwd(benchmark::State& st) {
  const int64_t n = st.range(0) * st.range(1);
  auto x = rand_vec(n, 17), dy = rand_vec(n, 18);
  std::vector<float> y(n), dx(n);
  LoopTimer timer;
  for (auto _ : st) {
    gelu_tanh_forward<float>(y.data(), x.data(), n);
    gelu_tanh_backward<float>(dx.data(), dy.data(), x.data(), n);
    benchmark::DoNotOptimize(dx.data());
  }
  set_counters(st, timer, 0, 5.0 * n * sizeof(float));
}
BENCHMARK(BM_gelu_tanh_fwd_bwd)->Args({4096, 2048})->Unit(benchmark::kMillisecond)->UseRealTime();

// AdamW over one 2048 x 2048 tensor (4.19M params). Bytes: reads p, g, m, v; writes p, m, v.
void BM_adamw_step(benchmark::State& st) {
  const int64_t n = st.range(0);
  auto p = rand_vec(n, 19), g = rand_vec(n, 20);
  std::vector<float> m(n, 0.0f), v(n, 0.0f);
  AdamWConfig cfg;
  cfg.lr = 1e-4f;
  int64_t step = 0;
  LoopTimer timer;
  for (auto _ : st) {
    adamw_step(p.data(), g.data(), m.data(), v.data(), n, cfg, ++step);
    benchmark::DoNotOptimize(p.data());
  }
  set_counters(st, timer, 0, 7.0 * n * sizeof(float));
}
BENCHMARK(BM_adamw_step)->Arg(2048 * 2048)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
