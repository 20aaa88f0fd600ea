// bench_sim.cpp — control steps per second of the humanoid (1 control step = 15 physics steps at 1/450 s),
// 1 and 2 threads, and the cost of the choices that make it cheap (contacts, integrator, solver iterations).
//
// Workload: VecEnv with 8 envs; each env holds the reference pose with small sinusoidal PD targets (actions), and
// is reset to the standing pose every 60 control steps (2 s), so the timing mixes standing, stepping and fallen
// states, like PD tracking does. items_per_second = control steps per second over all envs.
// Counter cpu_us_per_step: process CPU time per control step (all threads).
// Args: {threads, variant}; variant 0 = ours (Euler, Newton 8 iterations, body-floor contacts only),
// 1 = implicit integrator, 2 = + self collision, 3 = 100 solver iterations (MuJoCo's default).
#include <benchmark/benchmark.h>


#include <algorithm>
#include <cmath>
#include <ctime>
#include <vector>

#include "sim/env.h"
#include "tensor/parallel.h"

using namespace t2m::sim;

static double process_cpu_s() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static void BM_HumanoidControlStep(benchmark::State& state) {
  const int threads = (int)state.range(0), variant = (int)state.range(1);
  HumanoidOptions ho;
  if (variant == 1) ho.euler = false;
  if (variant == 2) ho.self_collision = true;
  if (variant == 3) ho.solver_iterations = 100;
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
  for (int i = 0; i < N; ++i) venv.env(i).reset(nullptr, nullptr, nullptr);
  const double cpu0 = process_cpu_s();
  for (auto _ : state) {
    if (t % 60 == 0)
      for (int i = 0; i < N; ++i) venv.env(i).reset(nullptr, nullptr, nullptr);
    for (int i = 0; i < N; ++i)
      for (int k = 0; k < A; ++k) act[(size_t)i * A + k] = hold[k] + 0.05f * std::sin(0.2f * t + k + i);
    venv.step(act.data(), obs.data());
    steps += N;
    ++t;
  }
  state.SetItemsProcessed(steps);
  // CPU seconds of all threads per control step: the cost that scales with cores on an idle machine
  // (wall-clock items_per_second is what a loaded, shared machine gives).
  state.counters["cpu_us_per_step"] = 1e6 * (process_cpu_s() - cpu0) / std::max(1L, steps);
  state.counters["contacts"] = venv.env(0).data()->ncon;
}
BENCHMARK(BM_HumanoidControlStep)
    ->ArgNames({"threads", "variant"})
    ->Args({1, 0})
    ->Args({2, 0})
    ->Args({1, 1})
    ->Args({1, 2})
    ->Args({1, 3})
    ->UseRealTime()
    ->MinTime(2.0)
    ->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
