// cpu_features.cpp — __builtin_cpu_supports, cached in function statics; the baseline switch is an atomic flag.
#include "tensor/cpu_features.h"

#include <atomic>

namespace t2m {

namespace {
std::atomic<bool> g_force_baseline{false};
}  // namespace

bool cpu_has_avx512() {
  static const bool has = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                          __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl");
  return has;
}

bool cpu_has_avx2() {
  static const bool has = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return has;
}

bool use_avx512_kernels() { return cpu_has_avx512() && !g_force_baseline.load(std::memory_order_relaxed); }

void force_baseline_isa(bool on) { g_force_baseline.store(on); }

}  // namespace t2m
