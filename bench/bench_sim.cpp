// bench_sim.cpp — control steps per second of the humanoid (1 control step = 15 physics steps at 1/450 s),
// 1 and 2 threads, and the cost of the choices that make it cheap (contacts, integrator, solver iterations).
//
// Workload: VecEnv with 8 envs; each env holds the reference pose with small sinusoidal PD targets (actions), and
// is reset to the standing pose every 60 control steps (2 s), so the timing mixes standing, stepping and fallen
// states, like PD tracking does (the targets depend on the step within that cycle, so every cycle is the same).
// items_per_second = control steps per second over all envs.
// Counters: cpu_us_per_step = process CPU time per control step (all threads); idle_cores_steps_per_s =
// threads * 1e6 / cpu_us_per_step, the rate `threads` otherwise idle cores would give (an estimate from CPU time,
// not a wall-clock measurement); load1 = the 1-minute load average at the end of the run (other processes).
// BM_EnvStepUndisturbed/variant:V: the same workload on one thread, Env by Env; the workload repeats exactly every
// 60 steps (the actions depend on the step within the cycle, the physics is deterministic), so the smallest thread CPU
// time of each (cycle step, env) over 10 cycles is that step's cost when no other process interrupted it or
// evicted its caches in between: undisturbed_us_per_step = their mean, undisturbed_steps_per_s = 1e6 / that.
// Args: {threads, variant}; variant 0 = ours (Euler, elliptic cones, PGS 6 iterations, body-floor contacts as
// predefined pairs), 1 = implicit integrator, 2 = + self collision, 3 = 100 solver iterations (MuJoCo's default),
// 4 = pyramidal Newton 8 (converged; our default before 2026-12-02), 5 = pyramidal PGS 4, 6 = pyramidal PGS 10
// (the default from 2026-12-02 until the switch to elliptic cones the same day), 7 = elliptic PGS 8, 8 = elliptic
// PGS 10.
#include <benchmark/benchmark.h>
#include <stdlib.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <vector>

#include "bench/lib/step_timer.h"
#include "sim/env.h"
#include "tensor/parallel.h"

using namespace t2m::sim;

// The solver / model variant of a benchmark row (see the file comment).
static HumanoidOptions variant_options(int variant) {
  HumanoidOptions ho;
  if (variant == 1) ho.euler = false;
  if (variant == 2) ho.self_collision = true;
  if (variant == 3) ho.solver_iterations = 100;
  if (variant == 4) {
    ho.solver = mjSOL_NEWTON;
    ho.solver_iterations = 8;
    ho.elliptic_cones = false;
  }
  if (variant == 5) ho.solver_iterations = 4, ho.elliptic_cones = false;
  if (variant == 6) ho.elliptic_cones = false, ho.solver_iterations = 10;  // the default until 2026-12-02 (late)
  if (variant == 7) ho.solver_iterations = 8;
  if (variant == 8) ho.solver_iterations = 10;
  return ho;
}

static void BM_HumanoidControlStep(benchmark::State& state) {
  const int threads = (int)state.range(0), variant = (int)state.range(1);
  const HumanoidOptions ho = variant_options(variant);
  auto h = Humanoid::create(ho);
  const int N = 8;
  VecEnv venv(h, N);
  const int A = venv.action_dim(), D = venv.obs_dim();
  std::vector<float> act((size_t)N * A), obs((size_t)N * D);
  // Action that holds the reference pose (hinge angle 0) per actuator.
  std::vector<float> hold(A);
  for (int k = 0; k < A; ++k) hold[k] = (float)venv.env(0).ctrl_to_action(k, 0.0);
  t2m::set_num_threads(threads);
  long steps = 0, t = 0;
  constexpr int kCycle = 60;  // reset period (2 s)
  for (int i = 0; i < N; ++i) venv.env(i).reset(nullptr, nullptr, nullptr);
  const double cpu0 = t2m::bench::process_cpu_seconds();
  for (auto _ : state) {
    const int c = (int)(t % kCycle);
    if (c == 0)
      for (int i = 0; i < N; ++i) venv.env(i).reset(nullptr, nullptr, nullptr);
    for (int i = 0; i < N; ++i)
      for (int k = 0; k < A; ++k) act[(size_t)i * A + k] = hold[k] + 0.05f * std::sin(0.2f * c + k + i);
    venv.step(act.data(), obs.data());
    steps += N;
    ++t;
  }
  state.SetItemsProcessed(steps);

  // CPU seconds of all threads per control step: the cost that scales with cores on an idle machine
  // (wall-clock items_per_second is what a loaded, shared machine gives).
  state.counters["cpu_us_per_step"] = 1e6 * (t2m::bench::process_cpu_seconds() - cpu0) / std::max(1L, steps);
  state.counters["idle_cores_steps_per_s"] = threads * 1e6 / std::max(1e-9, state.counters["cpu_us_per_step"].value);
  double load[1] = {0};
  if (getloadavg(load, 1) == 1) state.counters["load1"] = load[0];
  state.counters["contacts"] = venv.env(0).data()->ncon;
}
static double thread_cpu_s() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static void BM_EnvStepUndisturbed(benchmark::State& state) {
  const HumanoidOptions ho = variant_options((int)state.range(0));  // as in BM_HumanoidControlStep
  auto h = Humanoid::create(ho);
  // T2M_SIM_BENCH_CYCLES=1 makes it short enough for valgrind --tool=callgrind (instructions per step, docs/SIM.md).
  const char* cycles_env = std::getenv("T2M_SIM_BENCH_CYCLES");
  const int N = 8, kCycle = 60, kCycles = cycles_env ? std::max(1, std::atoi(cycles_env)) : 10;
  VecEnv venv(h, N);
  const int A = venv.action_dim(), D = venv.obs_dim();
  std::vector<float> act(A), obs(D), hold(A);
  for (int k = 0; k < A; ++k) hold[k] = (float)venv.env(0).ctrl_to_action(k, 0.0);
  std::vector<double> best((size_t)kCycle * N);
  long steps = 0;
  for (auto _ : state) {
    std::fill(best.begin(), best.end(), 1e30);
    for (int t = 0; t < kCycle * kCycles; ++t) {
      const int c = t % kCycle;
      for (int i = 0; i < N; ++i) {
        Env& e = venv.env(i);
        if (c == 0) e.reset(nullptr, nullptr, nullptr);
        for (int k = 0; k < A; ++k) act[k] = hold[k] + 0.05f * std::sin(0.2f * c + k + i);
        const double t0 = thread_cpu_s();
        e.step(act.data(), obs.data());
        best[(size_t)c * N + i] = std::min(best[(size_t)c * N + i], thread_cpu_s() - t0);
        ++steps;
      }
    }
  }
  double sum = 0;
  for (double b : best) sum += b;
  const double us = 1e6 * sum / best.size();
  state.SetItemsProcessed(steps);
  state.counters["undisturbed_us_per_step"] = us;
  state.counters["undisturbed_steps_per_s"] = 1e6 / us;
  double load[1] = {0};
  if (getloadavg(load, 1) == 1) state.counters["load1"] = load[0];
}
BENCHMARK(BM_EnvStepUndisturbed)->ArgName("variant")->Arg(0)->Arg(4)->Arg(5)->Arg(6)->Arg(7)->Arg(8)->Iterations(1)->UseRealTime()->Unit(benchmark::kMillisecond);

BENCHMARK(BM_HumanoidControlStep)
    ->ArgNames({"threads", "variant"})
    ->Args({1, 0})
    ->Args({2, 0})
    ->Args({1, 1})
    ->Args({1, 2})
    ->Args({1, 3})
    ->Args({1, 4})
    ->Args({2, 4})
    ->Args({1, 5})
    ->Args({1, 6})
    ->Args({2, 6})
    ->Args({1, 7})
    ->Args({2, 7})
    ->Args({2, 8})
    ->UseRealTime()
    ->MinTime(2.0)
    ->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
