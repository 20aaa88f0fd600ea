// cmd_bench.cpp — `t2m bench`: times our float GEMM on the micro-suite shapes and prints a table
// (shape, threads, median ms, GFLOP/s, % of FMA peak, best-rep GFLOP/s, CPU-time GFLOP/s, kernel), optionally with
// Eigen side by side. See bench/lib/gemm_bench.h for what each column means. --peak instead measures this machine's
// FMA peak per thread count (bench/lib/fma_peak.h), --bandwidth its memory bandwidth (bench/lib/mem_bandwidth.h),
// one line each.
// Only built with the benchmark library (T2M_HAVE_BENCH, i.e. -DT2M_BUILD_BENCH=ON).
#ifdef T2M_HAVE_BENCH
#include <cstdio>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "bench/lib/fma_peak.h"
#include "bench/lib/gemm_bench.h"
#include "bench/lib/mem_bandwidth.h"
#include "tensor/gemm.h"
#include "tensor/parallel.h"
#include "tensor/tensor.h"
#include "tools/command.h"

namespace {

struct BenchOptions {
  std::string threads = "1,2";
  std::string shapes = "all";
  std::string kernel = "auto";
  int pack_depth = 0;
  int reps = 10;
  int warmup = 2;
  bool eigen = false;
  bool peak = false;
  bool bandwidth = false;
};

std::vector<int> parse_threads(const std::string& s) {
  std::vector<int> v;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) {
    int n = 0;
    try {
      size_t used = 0;
      n = std::stoi(item, &used);
      if (used != item.size()) n = 0;
    } catch (const std::exception&) {
      n = 0;
    }
    if (n < 1) throw t2m::Error("bench: bad thread count '" + item + "' in --threads " + s);
    v.push_back(n);
  }
  if (v.empty()) throw t2m::Error("bench: empty --threads");
  return v;
}

void run_bench(const BenchOptions& o) {
  using namespace t2m::bench;
  const auto shapes = parse_gemm_shapes(o.shapes);
  const auto threads = parse_threads(o.threads);
  if (o.reps < 1) throw t2m::Error("bench: --reps must be >= 1, got " + std::to_string(o.reps));
  if (o.warmup < 0) throw t2m::Error("bench: --warmup must be >= 0, got " + std::to_string(o.warmup));
  if (o.peak || o.bandwidth) {  // "fma_peak threads N gflops X" / "mem_triad threads N gbps X" lines
    for (int t : threads) {
      if (o.peak) std::printf("fma_peak threads %d gflops %.1f\n", t, fma_peak_gflops(t));
      if (o.bandwidth) std::printf("mem_triad threads %d gbps %.1f\n", t, triad_gbps(t));
    }
    return;
  }
  t2m::gemm_force_kernel(o.kernel.c_str());
  t2m::gemm_force_pack_depth(o.pack_depth);
  const int saved = t2m::get_num_threads();
  std::printf("# t2m bench: float GEMM, median of %d reps after %d warm-up; peak = %.1f GFLOP/s per thread (measured)\n",
              o.reps, o.warmup, peak_gflops_per_core());
  std::printf("%-22s %7s %10s %9s %7s %9s %8s %-7s", "shape (MxNxK:op)", "threads", "ms", "GFLOP/s", "%peak",
              "best GF", "cpu GF", "kernel");
  if (o.eigen) std::printf(" %10s %9s %10s %6s", "eigen ms", "eigen GF", "eigen best", "ratio");
  std::printf("\n");
  for (const auto& s : shapes) {
    GemmOperands ops(s);
    for (int t : threads) {
      const GemmTiming r = time_gemm(ops, t, o.reps, o.warmup);
      // CPU-time GFLOP/s only for 1 thread (with more, descheduled workers and spin-waits make it meaningless).
      const std::string cpu = t == 1 ? std::to_string(int(r.cpu_gflops + 0.5)) : std::string("-");
      std::printf("%-22s %7d %10.3f %9.1f %6.1f%% %9.1f %8s %-7s", s.name().c_str(), t, r.median_ms, r.gflops,
                  r.pct_peak, s.flops() / (r.best_ms * 1e6), cpu.c_str(), t2m::gemm_kernel_name());
      if (o.eigen) {
        const GemmTiming e = time_eigen(ops, t, o.reps, o.warmup);
        std::printf(" %10.3f %9.1f %10.1f %5.2fx", e.median_ms, e.gflops, s.flops() / (e.best_ms * 1e6),
                    r.gflops / e.gflops);  // ratio of medians
      }
      std::printf("\n");
      std::fflush(stdout);
    }
  }
  t2m::set_num_threads(saved);
  t2m::gemm_force_kernel("auto");
  t2m::gemm_force_pack_depth(0);
}

void add_bench(CLI::App& app) {
  auto opts = std::make_shared<BenchOptions>();
  auto* c = app.add_subcommand("bench", "Time our float GEMM on the micro-suite shapes (GFLOP/s, % of FMA peak)");
  c->add_option("--threads", opts->threads, "comma list of thread counts")->capture_default_str();
  c->add_option("--reps", opts->reps, "timed repetitions per shape (the median is reported)")->capture_default_str();
  c->add_option("--warmup", opts->warmup, "untimed repetitions before timing")->capture_default_str();
  c->add_option("--shapes", opts->shapes, "micro | all | comma list of MxNxK[:nn|tn|nt|tt]")->capture_default_str();
  c->add_option("--kernel", opts->kernel, "auto | avx512 | avx2")->capture_default_str();
  c->add_option("--pack-depth", opts->pack_depth, "K blocks packed at once (0: by the L2 size; 1-8)")
      ->capture_default_str();
  c->add_flag("--eigen", opts->eigen, "also time Eigen on the same shapes");
  c->add_flag("--peak", opts->peak, "instead measure this machine's FP32 FMA peak (GFLOP/s) per thread count");
  c->add_flag("--bandwidth", opts->bandwidth,
              "instead (or with --peak) measure its memory bandwidth (STREAM triad, GB/s) per thread count");
  c->callback([opts] { run_bench(*opts); });
}

}  // namespace

T2M_COMMAND(add_bench);
#endif  // T2M_HAVE_BENCH
