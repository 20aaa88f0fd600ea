// step_timer.cpp — wall clock and process CPU time around the benchmark loop; counters per step.
#include "bench/lib/step_timer.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <memory>
#include <string>
#include <vector>

#include "autograd/profiler.h"
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

// A positive integer from the environment variable `name`, or 0 when it is unset; anything else is an error.
int env_count(const char* name) {
  const char* v = std::getenv(name);
  if (!v) return 0;
  char* end = nullptr;
  const long n = std::strtol(v, &end, 10);
  if (end == v || *end || n < 1 || n > 100000) {
    std::fprintf(stderr, "%s must be a positive integer, got '%s'\n", name, v);
    std::exit(2);
  }
  return int(n);
}
}  // namespace

int fixed_steps() { return env_count("T2M_BENCH_STEPS"); }

void steps_from_env(benchmark::internal::Benchmark* b) {
  if (const int n = fixed_steps()) b->Iterations(n);
}

void time_steps(benchmark::State& st, const std::function<void()>& step, double flops_per_step, int warmup) {
  if (const int w = env_count("T2M_BENCH_WARMUP")) warmup = w;
  for (int i = 0; i < warmup; ++i) step();
  std::vector<double> per_step, per_step_cpu;  // wall and process CPU seconds of each timed step
  per_step.reserve(4096);
  per_step_cpu.reserve(4096);
  std::unique_ptr<ag::Profiler> prof;
  if (const char* p = std::getenv("T2M_BENCH_PROFILE"))
    prof = std::make_unique<ag::Profiler>(/*by_shape=*/std::string(p) == "shapes");
  const double cpu0 = process_cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  for (auto _ : st) {
    const double c0 = process_cpu_seconds();
    const auto s0 = std::chrono::steady_clock::now();
    if (prof) prof->mark("(between steps)");
    step();
    if (prof) prof->mark("(after backward: optimizer)");
    per_step.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - s0).count());
    per_step_cpu.push_back(process_cpu_seconds() - c0);
  }
  if (prof)
    std::fprintf(stderr, "# ag::Profiler over %lld timed steps\n%s", (long long)st.iterations(),
                 prof->table((int64_t)st.iterations(), 30).c_str());
  const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu = process_cpu_seconds() - cpu0, it = (double)st.iterations();
  const double gflops = flops_per_step * it / sec * 1e-9;
  st.counters["ms"] = sec / it * 1e3;
  st.counters["median_ms"] = median(per_step) * 1e3;
  st.counters["min_ms"] = *std::min_element(per_step.begin(), per_step.end()) * 1e3;
  st.counters["cpu_ms"] = cpu / it * 1e3;
  st.counters["median_cpu_ms"] = median(per_step_cpu) * 1e3;
  st.counters["GFLOP/s"] = gflops;
  const double peak = peak_gflops_per_core() * get_num_threads();
  st.counters["peak_GFLOP/s"] = peak;
  st.counters["%peak"] = 100.0 * gflops / peak;
  st.counters["threads"] = get_num_threads();
}

}  // namespace t2m::bench
