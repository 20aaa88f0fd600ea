// step_timer.cpp — wall clock and process CPU time around the benchmark loop; counters per step.
#include "bench/lib/step_timer.h"

#include <chrono>
#include <ctime>

#include "bench/lib/gemm_bench.h"
#include "tensor/parallel.h"

namespace t2m::bench {

double process_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

void time_steps(benchmark::State& st, const std::function<void()>& step, double flops_per_step, int warmup) {
  for (int i = 0; i < warmup; ++i) step();
  const double cpu0 = process_cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  for (auto _ : st) step();
  const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu = process_cpu_seconds() - cpu0, it = (double)st.iterations();
  const double gflops = flops_per_step * it / sec * 1e-9;
  st.counters["ms"] = sec / it * 1e3;
  st.counters["cpu_ms"] = cpu / it * 1e3;
  st.counters["GFLOP/s"] = gflops;
  st.counters["%peak"] = 100.0 * gflops / (kPeakGflopsPerCore * get_num_threads());
  st.counters["threads"] = get_num_threads();
}

}  // namespace t2m::bench
