// step_timer.h — the timing every bench/ program shares: process CPU time, and a timed loop over whole steps
// (a training step, an attention forward + backward) that sets the counters the side-by-side scripts read.
#pragma once
#include <benchmark/benchmark.h>

#include <functional>

namespace t2m::bench {

// CPU seconds used so far by all threads of this process (CLOCK_PROCESS_CPUTIME_ID).
double process_cpu_seconds();

// Calls step `warmup` times untimed (allocator caches, scratch buffers, optimizer state), then once per benchmark
// iteration, and sets the counters: ms (wall clock per step, mean), median_ms (the median step: torch_ref.py's
// statistic), cpu_ms (process CPU time per step, all threads),
// GFLOP/s (flops_per_step per wall second), %peak (against kPeakGflopsPerCore x threads), threads.
void time_steps(benchmark::State& st, const std::function<void()>& step, double flops_per_step, int warmup = 1);

}  // namespace t2m::bench
