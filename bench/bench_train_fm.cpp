// bench_train_fm.cpp — one full training step of the anchor's fm configs (shared/anchor/REFERENCE.md "fm",
// torch_ref.py fm_case): zero grad, x0 ~ N(0, I), t ~ U[0, 1), x_t = (1 - t) x0 + t x1 (Eq 14), v = model(x_t, t,
// tok), loss = mse(v, x1 - x0) (Eq 15), backward, AdamW (lr 1e-4, weight decay 0.01 on every parameter, as
// torch.optim.AdamW(model.parameters())), on the flow generator (models/text2bfm/generator.h) with text tokens
// (B, 24, 768) and no condition dropout (the anchor has none; same work per step).
// Configs: fm-small B{32, 256} x Tm{8, 16}; fm-paper B32 Tm8, B32 Tm16, B256 Tm8.
// Counters: ms (wall clock per step), cpu_ms (process CPU time per step over all threads: less sensitive to other
// processes holding a core), GFLOP/s (Linear + attention-matmul FLOPs counted as torch_ref counts them: 3 x the
// forward FLOPs, so the rates compare directly), %peak (GFLOP/s against the measured peak_GFLOP/s).
// fm_paper_kv_form: fm-paper B32 Tm8 with every cross-attention in the K/V-projection form (mha_cross), against
// fm_paper's value projection after the weighted sum (autograd/ops_mha_ctx.h).
// Also BM_fm_attention: the attention core alone (fwd + bwd) at the generator's head shapes on each path.
// Run: build-NAME/bench_train_fm --benchmark_min_time=2   (threads: OMP_NUM_THREADS, default 2 on this VM).
#include <benchmark/benchmark.h>

#include "bench/lib/step_timer.h"
#include "autograd/ops_mha_ctx.h"
#include "models/text2bfm/generator.h"
#include "tensor/fused/attention.h"
#include "nn/loss_flow.h"
#include "nn/optim_adamw.h"
#include "tensor/parallel.h"
#include "tensor/rng.h"

using namespace t2m;
using namespace t2m::text2bfm;

namespace {

constexpr int64_t kTextLen = 24;

// Forward FLOPs of the anchor FlowTransformer as torch_ref counts them: 2 * rows * in * out per Linear, plus
// 2 * (QK^T + PV) products per attention (4 * B * Tq * Tk * D).
double fm_forward_flops(const FlowGeneratorConfig& c, int64_t B, int64_t Tm, int64_t L) {
  const double W = (double)c.width, Cx = (double)c.ctx_dim, A = (double)c.adapter.width, bt = (double)(B * Tm),
               bl = (double)(B * L), b = (double)B;
  auto lin = [](double rows, double in, double out) { return 2.0 * rows * in * out; };
  double f = lin(bt, (double)c.latent, W) + lin(b, (double)c.freq_dim, W) + lin(b, W, W);
  if (c.adapter.tok_dim != c.adapter.width) f += lin(bl, (double)c.adapter.tok_dim, A);
  f += (double)c.adapter.depth * (lin(bl, A, 3 * A) + lin(bl, A, A) + lin(bl, A, 4 * A) + lin(bl, 4 * A, A) +
                                  4.0 * b * (double)L * (double)L * A);
  f += lin(bl, A, Cx);
  const double blk = lin(b, W, 6 * W) + lin(bt, W, 3 * W) + lin(bt, W, W) + 4.0 * b * Tm * Tm * W +  // self
                     lin(bt, W, W) + lin(bl, Cx, 2 * W) + lin(bt, W, W) + 4.0 * b * Tm * L * W +      // cross
                     lin(bt, W, 4 * W) + lin(bt, 4 * W, W);                                         // MLP
  f += (double)c.depth * blk;
  return f + lin(b, W, 2 * W) + lin(bt, W, (double)c.latent);
}

// cross_form: "auto" (the cost rule of autograd/ops_mha_ctx.h) or "never" (always the K/V-projection form: the
// comparison for the value projection after the weighted sum).
void BM_train_fm(benchmark::State& st, const std::string& name, const char* cross_form = "auto") {
  const int64_t B = st.range(0), Tm = st.range(1);
  ag::mha_cross_ctx_force(cross_form);
  const FlowGeneratorConfig cfg = FlowGeneratorConfig::by_name(name);
  Generator gen(1);
  FlowGenerator model(cfg, gen);
  model.train();
  nn::AdamWOptions ao;
  ao.lr = 1e-4;
  ao.weight_decay = 0.01;
  nn::AdamW opt(model.named_parameters(), ao);
  const ag::Variable x1(rand_normal({B, Tm, cfg.latent}, gen));
  const ag::Variable tok(rand_normal({B, kTextLen, cfg.adapter.tok_dim}, gen));
  auto step = [&] {
    opt.zero_grad();
    const nn::FlowSample s = nn::sample_flow_pair(x1.data(), gen);  // t, x0, x_t (Eq 14)
    const ag::Variable v = model.forward(ag::Variable(s.x_t), s.t, tok);
    ag::Variable loss = nn::flow_matching_loss(v, ag::Variable(s.x0), x1);  // Eq 15
    loss.backward();
    opt.step();
    return loss.item();
  };
  bench::time_steps(st, [&] { benchmark::DoNotOptimize(step()); }, 3.0 * fm_forward_flops(cfg, B, Tm, kTextLen));
  st.counters["params_M"] = (double)model.num_parameters() * 1e-6;
  ag::mha_cross_ctx_force("auto");
}

// The attention core alone (forward + backward, all three input gradients) at the generator's head shapes, on the
// path given: "small" (per-head loops) or "gemm" (gemm_batched). Args: B, H, Tq, Tk, d.
void BM_fm_attention(benchmark::State& st, const char* path) {
  fused::AttentionShape s;
  s.B = st.range(0), s.H = st.range(1), s.Tq = st.range(2), s.Tk = st.range(3), s.d = st.range(4);
  Generator gen(2);
  const Tensor q = rand_normal({s.B, s.H, s.Tq, s.d}, gen), k = rand_normal({s.B, s.H, s.Tk, s.d}, gen);
  const Tensor v = rand_normal({s.B, s.H, s.Tk, s.d}, gen), g = rand_normal({s.B, s.H, s.Tq, s.d}, gen);
  Tensor out = Tensor::empty(q.shape()), att = Tensor::empty({s.B, s.H, s.Tq, s.Tk});
  Tensor dq = Tensor::empty(q.shape()), dk = Tensor::empty(k.shape()), dv = Tensor::empty(v.shape());
  fused::attention_force_path(path);
  auto run = [&] {
    fused::attention_forward<float>(out.data<float>(), att.data<float>(), q.data<float>(), k.data<float>(),
                                    v.data<float>(), nullptr, s);
    fused::attention_backward<float>(dq.data<float>(), dk.data<float>(), dv.data<float>(), g.data<float>(),
                                     att.data<float>(), q.data<float>(), k.data<float>(), v.data<float>(), s);
  };
  bench::time_steps(st, run, 3.0 * fused::attention_forward_flops(s));
  fused::attention_force_path("auto");
}

}  // namespace

BENCHMARK_CAPTURE(BM_fm_attention, small, "small")
    ->ArgNames({"B", "H", "Tq", "Tk", "d"})
    ->Args({256, 8, 16, 16, 64})
    ->Args({256, 8, 8, 24, 64})
    ->Args({256, 8, 24, 24, 96})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_fm_attention, gemm, "gemm")
    ->ArgNames({"B", "H", "Tq", "Tk", "d"})
    ->Args({256, 8, 16, 16, 64})
    ->Args({256, 8, 8, 24, 64})
    ->Args({256, 8, 24, 24, 96})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

BENCHMARK_CAPTURE(BM_train_fm, fm_small, std::string("fm-small"))
    ->Apply(bench::steps_from_env)
    ->ArgNames({"B", "Tm"})
    ->Args({32, 8})
    ->Args({256, 8})
    ->Args({32, 16})
    ->Args({256, 16})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_train_fm, fm_paper, std::string("fm-paper"))
    ->Apply(bench::steps_from_env)
    ->ArgNames({"B", "Tm"})
    ->Args({32, 8})
    ->Args({32, 16})
    ->Args({256, 8})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_train_fm, fm_paper_kv_form, std::string("fm-paper"), "never")
    ->Apply(bench::steps_from_env)
    ->ArgNames({"B", "Tm"})
    ->Args({32, 8})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

BENCHMARK_MAIN();
