// fma_peak.h — this machine's float32 FMA peak, measured: the VMs seen so far range from ~114 (Zen 4) and ~176
// (Intel) to ~220 (Zen 5) GFLOP/s per core, so every % of peak in bench/ is against this figure
// (bench::peak_gflops_per_core()), and the fm side by side bounds each step's ratio by it (how fast the step could
// be if all its FLOPs ran at the peak).
#pragma once

namespace t2m::bench {

// GFLOP/s of `threads` threads each running independent fused multiply-adds on the widest vectors the GEMM uses
// (AVX-512 where the CPU has it, else AVX2): 12 accumulator chains per thread (more than latency x ports on the
// hosts seen), the best of `tries` runs of 3 GFLOP per thread. A ceiling no real kernel reaches (our GEMM's
// micro-kernel on hot panels: 92-100 %).
double fma_peak_gflops(int threads, int tries = 3);

}  // namespace t2m::bench
