// parallel.h — the thread policy: one process-wide thread count used by every OpenMP region.
#pragma once
#include <cstdint>

namespace t2m {

// Sets the number of threads for all kernels (>= 1). Default: OMP_NUM_THREADS or the number of cores.
void set_num_threads(int n);
int get_num_threads();
// Elementwise ops below this many elements run on one thread (threading overhead dominates).
constexpr int64_t kParallelGrain = 32768;

}  // namespace t2m
