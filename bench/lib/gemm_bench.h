// gemm_bench.h — reusable GEMM timing for `t2m bench` and bench/bench_gemm.cpp.
//
// Shapes are M×N×K (C is M×N, the reduction is K) with a transpose variant: "nn" is C = A B (forward),
// "tn" is C = A^T B (weight gradient), "nt" is C = A B^T (input gradient). The micro suite is the sgemm list of
// /work/shared/anchor/REFERENCE.md. FLOPs = 2·M·N·K; % of peak is against peak_gflops_per_core() × threads.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace t2m::bench {

// This machine's FP32 FMA peak on one core, measured once per process (fma_peak_gflops(1), bench/lib/fma_peak.h;
// ~80 ms on the first call): every % of peak of the benchmarks is against it x threads. (Until session 43 a fixed
// 220, the Zen 5 host's figure: ~114.6 on the Zen 4 VMs, ~176 on the Intel ones.)
double peak_gflops_per_core();

struct GemmShape {
  int64_t M = 0, N = 0, K = 0;
  bool trans_a = false, trans_b = false;
  std::string name() const;  // "1024x1024x1024" or "4096x512x512:tn"
  double flops() const { return 2.0 * double(M) * double(N) * double(K); }
};

// The five micro-suite shapes (256³, 1024³, 1000³, 4096×512×512, 4096×2048×512), forward only ("nn").
std::vector<GemmShape> gemm_micro_shapes();
// The same shapes in the three variants (nn, tn, nt).
std::vector<GemmShape> gemm_all_shapes();
// Parses "micro", "all" or a comma list of MxNxK[:nn|tn|nt|tt]. Throws t2m::Error on malformed input.
std::vector<GemmShape> parse_gemm_shapes(const std::string& spec);

// Operands allocated and filled once (uniform [-1, 1)); C written once so timing sees no first-touch faults.
struct GemmOperands {
  GemmShape shape;
  std::vector<float> A, B, C;
  explicit GemmOperands(const GemmShape& s);
  void run();           // one C = op(A) op(B) with our gemm
  void run_eigen();     // the same product with Eigen (threads set by set_eigen_threads)
};
void set_eigen_threads(int n);

struct GemmTiming {
  double median_ms = 0, best_ms = 0;
  double gflops = 0;    // at the median
  double pct_peak = 0;  // gflops / (peak_gflops_per_core() * threads)
  // flops / (process CPU seconds of the fastest rep) × threads: the speed while actually on a core. On a quiet
  // machine it equals the wall-clock figure; on a shared, oversubscribed one it filters out time spent
  // descheduled. Meaningful for 1 thread only (with more, a descheduled worker's time is simply missing).
  double cpu_gflops = 0;
};

// Sets t2m's thread count, runs `warmup` untimed calls then `reps` timed ones; median and best of reps.
GemmTiming time_gemm(GemmOperands& ops, int threads, int reps, int warmup);
GemmTiming time_eigen(GemmOperands& ops, int threads, int reps, int warmup);

}  // namespace t2m::bench
