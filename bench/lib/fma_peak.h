// fma_peak.h — this machine's float32 FMA peak, measured: the %peak columns elsewhere divide by a fixed 220 GFLOP/s
// per thread (the AMD Zen 5 host of the early sessions), while the VMs seen since range from ~114 (Zen 4) to ~176
// (Intel) per core. The side-by-side scripts use the measured figure for % of this host's peak and for the FLOP
// bound of a step (how fast it could be if all its FLOPs ran at that peak).
#pragma once

namespace t2m::bench {

// GFLOP/s of `threads` threads each running independent fused multiply-adds on the widest vectors the GEMM uses
// (AVX-512 where the CPU has it, else AVX2): 12 accumulator chains per thread (more than latency x ports on the
// hosts seen), the best of `tries` runs of 3 GFLOP per thread. A ceiling no real kernel reaches (our GEMM's
// micro-kernel on hot panels: 92-100 %).
double fma_peak_gflops(int threads, int tries = 3);

}  // namespace t2m::bench
