// bench_gemm.cpp — Google Benchmark: our float GEMM vs Eigen on the micro-suite shapes of
// /work/shared/anchor/REFERENCE.md (256³, 1024³, 1000³, 4096×512×512, 4096×2048×512; M×N×K), each as the forward
// product A·B ("nn") and the two backward products A^T·B ("tn") and A·B^T ("nt"), on 1 and 2 threads.
// Counters: GFLOP/s and % of this machine's measured FMA peak (bench::peak_gflops_per_core() per thread).
// Wall-clock time per call (manual timing; the work is multi-threaded).
// gemm/wgrad/{plain,stream}: weight-gradient products of fm-paper B32 (dW = dY^T X, out x in from K rows) written
// by gemm (beta 0) or gemm_stream, C rotating over 16 matrices as a training step's gradients do (each written once).
// gemm/read_a/{packed,in_place}: fm-paper's forward (nt) and input-gradient (nn) products and 1024^3 on 2 threads
// with A packed or read in place (gemm_force_read_a; the automatic choice reads in place with <= 512 columns per
// thread).
//
//   build-x/bench_gemm --benchmark_filter='ours/1024' --benchmark_repetitions=5 --benchmark_report_aggregates_only
//   build-x/bench_gemm --benchmark_filter='wgrad' --benchmark_repetitions=3
//   build-x/bench_gemm --benchmark_filter='read_a' --benchmark_repetitions=5 --benchmark_report_aggregates_only
#include <benchmark/benchmark.h>

#include <chrono>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "bench/lib/gemm_bench.h"
#include "tensor/gemm.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"

namespace {

using t2m::bench::GemmOperands;
using t2m::bench::GemmShape;

// Times each call by hand (UseManualTime) so that the counters are plain numbers, not "/s" rates.
template <typename F>
void timed_loop(benchmark::State& state, const GemmShape& s, int threads, F&& fn) {
  fn();  // warm the packing buffers and C
  double total_s = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    fn();
    const auto t1 = std::chrono::steady_clock::now();
    const double dt = std::chrono::duration<double>(t1 - t0).count();
    state.SetIterationTime(dt);
    total_s += dt;
  }
  const double gflops = s.flops() * 1e-9 * double(state.iterations()) / total_s;
  state.counters["GFLOP/s"] = gflops;
  state.counters["%peak"] = 100.0 * gflops / (t2m::bench::peak_gflops_per_core() * threads);
}

void bm_ours(benchmark::State& state, std::shared_ptr<GemmOperands> ops, int threads) {
  t2m::set_num_threads(threads);
  timed_loop(state, ops->shape, threads, [&] {
    ops->run();
    benchmark::DoNotOptimize(ops->C.data());
    benchmark::ClobberMemory();
  });
}

void bm_eigen(benchmark::State& state, std::shared_ptr<GemmOperands> ops, int threads) {
  t2m::bench::set_eigen_threads(threads);
  timed_loop(state, ops->shape, threads, [&] {
    ops->run_eigen();
    benchmark::DoNotOptimize(ops->C.data());
    benchmark::ClobberMemory();
  });
}

// dW (out x in) = dY^T (out x rows) X (rows x in), 2 threads, into 16 rotating C matrices.
void bm_wgrad(benchmark::State& state, int64_t out, int64_t in, int64_t rows, bool stream) {
  t2m::set_num_threads(2);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> dy(size_t(rows * out)), x(size_t(rows * in));
  for (auto& v : dy) v = u(rng);
  for (auto& v : x) v = u(rng);
  std::vector<t2m::Tensor> dw;
  for (int i = 0; i < 16; ++i) dw.push_back(t2m::Tensor::zeros({out, in}));
  size_t next = 0;
  const GemmShape s{out, in, rows, true, false};
  timed_loop(state, s, 2, [&] {
    float* c = dw[next++ % dw.size()].data<float>();
    if (stream)
      t2m::gemm_stream(true, false, out, in, rows, 1.0f, dy.data(), out, x.data(), in, c, in);
    else
      t2m::gemm(true, false, out, in, rows, 1.0f, dy.data(), out, x.data(), in, 0.0f, c, in);
    benchmark::ClobberMemory();
  });
}

// bm_ours on 2 threads with A read as `mode` says.
void bm_read_a(benchmark::State& state, std::shared_ptr<GemmOperands> ops, const char* mode) {
  t2m::gemm_force_read_a(mode);
  bm_ours(state, std::move(ops), 2);
  t2m::gemm_force_read_a("auto");
}

}  // namespace

int main(int argc, char** argv) {
  struct Wgrad { int64_t out, in, rows; };
  for (const Wgrad w : {Wgrad{3072, 512, 32}, Wgrad{2048, 512, 256}, Wgrad{512, 2048, 512}})
    for (bool stream : {false, true}) {
      const std::string name = std::string("gemm/wgrad/") + (stream ? "stream/" : "plain/") + std::to_string(w.out) +
                               "x" + std::to_string(w.in) + "x" + std::to_string(w.rows);
      benchmark::RegisterBenchmark(name.c_str(), bm_wgrad, w.out, w.in, w.rows, stream)
          ->UseManualTime()
          ->Unit(benchmark::kMillisecond);
    }
  for (const GemmShape& s : {GemmShape{512, 512, 2048, false, true}, GemmShape{512, 2048, 512, false, true},
                             GemmShape{512, 512, 512, false, false}, GemmShape{768, 1024, 1024, false, true},
                             GemmShape{768, 768, 3072, false, false}, GemmShape{1024, 1024, 1024, false, false}}) {
    auto ops = std::make_shared<GemmOperands>(s);
    for (const char* mode : {"packed", "in_place"})
      benchmark::RegisterBenchmark(("gemm/read_a/" + std::string(mode) + "/" + s.name()).c_str(), bm_read_a, ops, mode)
          ->UseManualTime()
          ->Unit(benchmark::kMillisecond);
  }
  for (const GemmShape& s : t2m::bench::gemm_all_shapes()) {
    auto ops = std::make_shared<GemmOperands>(s);  // shared by both libraries and thread counts
    for (int threads : {1, 2}) {
      const std::string suffix = s.name() + "/threads:" + std::to_string(threads);
      benchmark::RegisterBenchmark(("gemm/ours/" + suffix).c_str(), bm_ours, ops, threads)
          ->UseManualTime()
          ->Unit(benchmark::kMillisecond);
      benchmark::RegisterBenchmark(("gemm/eigen/" + suffix).c_str(), bm_eigen, ops, threads)
          ->UseManualTime()
          ->Unit(benchmark::kMillisecond);
    }
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
