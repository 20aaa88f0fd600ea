// step_timer.h — the timing every bench/ program shares: process CPU time, and a timed loop over whole steps
// (a training step, an attention forward + backward) that sets the counters the side-by-side scripts read.
#pragma once
#include <benchmark/benchmark.h>

#include <functional>

namespace t2m::bench {

// CPU seconds used so far by all threads of this process (CLOCK_PROCESS_CPUTIME_ID).
double process_cpu_seconds();

// Calls step `warmup` times untimed (allocator caches, scratch buffers, optimizer state; T2M_BENCH_WARMUP=N
// overrides it), then once per benchmark iteration, and sets the counters: ms (wall clock per step, mean), median_ms
// (the median step: torch_ref.py's statistic), min_ms (the fastest step), cpu_ms (process CPU time per step, all
// threads, mean), median_cpu_ms (the median step's CPU time), GFLOP/s (flops_per_step per wall second), %peak
// (against peak_GFLOP/s), peak_GFLOP/s (this machine's measured FMA peak x threads), threads. With
// T2M_BENCH_PROFILE set, the timed steps run under an ag::Profiler and its per-op table (ms per step) goes to stderr
// (T2M_BENCH_PROFILE=shapes: one row per op and input shapes).
void time_steps(benchmark::State& st, const std::function<void()>& step, double flops_per_step, int warmup = 1);

// For ->Apply(): with T2M_BENCH_STEPS=N in the environment, every run of the benchmark times exactly N steps of one
// model after its warm-up (torch_ref.py's protocol: warm-up steps, then the median of the timed ones), instead of
// Google Benchmark's iteration search, which builds a new model for each trial run. Unset: no change.
// (Google Benchmark allows either a fixed iteration count or MinTime: with MinTime, register it only when
// fixed_steps() is 0.)
void steps_from_env(benchmark::internal::Benchmark* b);
int fixed_steps();  // T2M_BENCH_STEPS, or 0 when unset

}  // namespace t2m::bench
