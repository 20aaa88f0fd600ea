// step_timer.cpp — wall clock and process CPU time around the benchmark loop; counters per step.
#include "bench/lib/step_timer.h"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <vector>

#include "bench/lib/gemm_bench.h"
#include "tensor/parallel.h"

namespace t2m::bench {

double process_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

namespace {
// The median as Python's statistics.median takes it (the mean of the two middle values for an even count).
double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}
}  // namespace

void time_steps(benchmark::State& st, const std::function<void()>& step, double flops_per_step, int warmup) {
  for (int i = 0; i < warmup; ++i) step();
  std::vector<double> per_step;  // seconds of each timed step
  per_step.reserve(4096);
  const double cpu0 = process_cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  for (auto _ : st) {
    const auto s0 = std::chrono::steady_clock::now();
    step();
    per_step.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - s0).count());
  }
  const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu = process_cpu_seconds() - cpu0, it = (double)st.iterations();
  const double gflops = flops_per_step * it / sec * 1e-9;
  st.counters["ms"] = sec / it * 1e3;
  st.counters["median_ms"] = median(per_step) * 1e3;
  st.counters["cpu_ms"] = cpu / it * 1e3;
  st.counters["GFLOP/s"] = gflops;
  st.counters["%peak"] = 100.0 * gflops / (kPeakGflopsPerCore * get_num_threads());
  st.counters["threads"] = get_num_threads();
}

}  // namespace t2m::bench
