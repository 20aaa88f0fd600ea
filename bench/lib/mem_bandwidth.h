// mem_bandwidth.h — this machine's main-memory bandwidth right now, measured: on the shared VMs it moves within a
// minute (a triad on 4 KB pages read 29-50 GB/s on 2 threads, 3 s apart, while the FMA peak held at 234 GFLOP/s;
// session 44). The side-by-side scripts print it around each measurement, as a record of the host's state.
#pragma once

namespace t2m::bench {

// GB/s of `threads` threads running the STREAM triad c = a + s b over three 64 MB float arrays on 2 MB pages where
// the kernel allows (12 bytes per element: two reads and a write; the write's read-for-ownership not counted), the
// best of `tries` passes after one untimed pass that faults c in. ~71 GB/s on 2 threads of the Zen 4 host when
// quiet.
double triad_gbps(int threads, int tries = 3);

}  // namespace t2m::bench
