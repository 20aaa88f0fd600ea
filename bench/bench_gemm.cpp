// bench_gemm.cpp — Google Benchmark: our float GEMM vs Eigen on the micro-suite shapes of
// /work/shared/anchor/REFERENCE.md (256³, 1024³, 1000³, 4096×512×512, 4096×2048×512; M×N×K), each as the forward
// product A·B ("nn") and the two backward products A^T·B ("tn") and A·B^T ("nt"), on 1 and 2 threads.
// Counters: GFLOP/s and % of FMA peak (220 GFLOP/s per thread). Wall-clock time (the work is multi-threaded).
//
//   build-x/bench_gemm --benchmark_filter='ours/1024' --benchmark_repetitions=5 --benchmark_report_aggregates_only
#include <benchmark/benchmark.h>

#include <memory>
#include <string>

#include "bench/lib/gemm_bench.h"
#include "tensor/parallel.h"

namespace {

using t2m::bench::GemmOperands;
using t2m::bench::GemmShape;

void set_counters(benchmark::State& state, const GemmShape& s, int threads) {
  const double gflop = s.flops() * 1e-9;
  state.counters["GFLOP/s"] = benchmark::Counter(gflop, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["%peak"] = benchmark::Counter(100.0 * gflop / (t2m::bench::kPeakGflopsPerCore * threads),
                                               benchmark::Counter::kIsIterationInvariantRate);
}

void bm_ours(benchmark::State& state, std::shared_ptr<GemmOperands> ops, int threads) {
  t2m::set_num_threads(threads);
  ops->run();  // warm the packing buffers and C
  for (auto _ : state) {
    ops->run();
    benchmark::DoNotOptimize(ops->C.data());
    benchmark::ClobberMemory();
  }
  set_counters(state, ops->shape, threads);
}

void bm_eigen(benchmark::State& state, std::shared_ptr<GemmOperands> ops, int threads) {
  t2m::bench::set_eigen_threads(threads);
  ops->run_eigen();
  for (auto _ : state) {
    ops->run_eigen();
    benchmark::DoNotOptimize(ops->C.data());
    benchmark::ClobberMemory();
  }
  set_counters(state, ops->shape, threads);
}

}  // namespace

int main(int argc, char** argv) {
  for (const GemmShape& s : t2m::bench::gemm_all_shapes()) {
    auto ops = std::make_shared<GemmOperands>(s);  // shared by both libraries and thread counts
    for (int threads : {1, 2}) {
      const std::string suffix = s.name() + "/threads:" + std::to_string(threads);
      benchmark::RegisterBenchmark(("gemm/ours/" + suffix).c_str(), bm_ours, ops, threads)
          ->UseRealTime()
          ->Unit(benchmark::kMillisecond);
      benchmark::RegisterBenchmark(("gemm/eigen/" + suffix).c_str(), bm_eigen, ops, threads)
          ->UseRealTime()
          ->Unit(benchmark::kMillisecond);
    }
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
