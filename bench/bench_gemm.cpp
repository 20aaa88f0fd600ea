// bench_gemm.cpp — Google Benchmark: our float GEMM vs Eigen on the micro-suite shapes of
// /work/shared/anchor/REFERENCE.md (256³, 1024³, 1000³, 4096×512×512, 4096×2048×512; M×N×K), each as the forward
// product A·B ("nn") and the two backward products A^T·B ("tn") and A·B^T ("nt"), on 1 and 2 threads.
// Counters: GFLOP/s and % of FMA peak (220 GFLOP/s per thread). Wall-clock time per call (manual timing; the work is multi-threaded).
//
//   build-x/bench_gemm --benchmark_filter='ours/1024' --benchmark_repetitions=5 --benchmark_report_aggregates_only
#include <benchmark/benchmark.h>

#include <chrono>
#include <memory>
#include <string>

#include "bench/lib/gemm_bench.h"
#include "tensor/parallel.h"

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
  state.counters["%peak"] = 100.0 * gflops / (t2m::bench::kPeakGflopsPerCore * threads);
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

}  // namespace

int main(int argc, char** argv) {
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
