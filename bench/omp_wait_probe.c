// omp_wait_probe.c — measuring aid (never built by CMake, never run by tests or CI): an LD_PRELOAD shim over
// libgomp's GOMP_parallel that times every OpenMP parallel region of a program and, for 2-thread teams, how long
// each thread sat idle at the region's end waiting for the other. Per region function it prints the calls, the
// summed wall time, the summed waits of thread 0 (the calling thread) and of thread 1, and the summed delay of
// thread 1's start (negative: it started first). A wait is idle core time: on 2 threads, half of it is wall time.
//
// Build and run (any binary; the table goes to $OMP_WAIT_PROBE_OUT, default /tmp/omp_wait_probe.txt, at exit; the
// sort below orders it by thread 0's wait):
//     gcc -O2 -Wall -Wextra -Werror -shared -fPIC -fopenmp bench/omp_wait_probe.c -o /tmp/omp_wait_probe.so -ldl
//     OMP_NUM_THREADS=2 LD_PRELOAD=/tmp/omp_wait_probe.so build/bench_train_vae --benchmark_filter='B:256/T:64'
//     sort -t= -k4 -rn /tmp/omp_wait_probe.txt | head -20 | while read bin off rest; do
//       echo "$(addr2line -f -C -e $bin $off | head -1 | cut -c1-90) $rest"; done
// Each line starts with the object file and the region function's offset in it, for addr2line. Regions opened
// through other entry points (GOMP_parallel_start, tasks) are not seen. Timing adds ~0.1 us per region.
#define _GNU_SOURCE
#include <dlfcn.h>
#include <omp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

typedef void (*region_fn)(void*);

enum { kSlots = 4096, kMaxThreads = 64 };

struct region_call {
  region_fn fn;
  void* data;
  double start[kMaxThreads], finish[kMaxThreads];
};

struct region_stats {
  region_fn fn;
  long calls;
  double total, wait0, wait1, late1;
};

static void (*real_gomp_parallel)(region_fn, void*, unsigned, unsigned);
static struct region_stats stats[kSlots];

static double now_s(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + (double)t.tv_nsec * 1e-9;
}

static void timed_body(void* p) {
  struct region_call* c = p;
  const int t = omp_get_thread_num();
  if (t < kMaxThreads) c->start[t] = now_s();
  c->fn(c->data);
  if (t < kMaxThreads) c->finish[t] = now_s();
}

static void write_table(void) {
  const char* path = getenv("OMP_WAIT_PROBE_OUT");
  FILE* f = fopen(path ? path : "/tmp/omp_wait_probe.txt", "w");
  if (!f) return;
  for (int i = 0; i < kSlots; ++i) {
    const struct region_stats* s = &stats[i];
    if (!s->calls) continue;
    Dl_info info;
    const int known = dladdr((void*)s->fn, &info);
    fprintf(f, "%s 0x%lx n=%ld total=%.1fms wait0=%.1fms wait1=%.1fms late1=%.1fms\n",
            known && info.dli_fname ? info.dli_fname : "?",
            known ? (unsigned long)((char*)s->fn - (char*)info.dli_fbase) : 0UL, s->calls, s->total * 1e3,
            s->wait0 * 1e3, s->wait1 * 1e3, s->late1 * 1e3);
  }
  fclose(f);
}

void GOMP_parallel(region_fn fn, void* data, unsigned num_threads, unsigned flags) {
  if (!real_gomp_parallel) {
    *(void**)&real_gomp_parallel = dlsym(RTLD_NEXT, "GOMP_parallel");
    atexit(write_table);
  }
  struct region_call c = {fn, data, {0}, {0}};
  const double t0 = now_s();
  real_gomp_parallel(timed_body, &c, num_threads, flags);
  const double t1 = now_s();
  // Open addressing on the function pointer (regions are called from one thread at a time in these programs).
  unsigned h = (unsigned)(((uintptr_t)fn >> 4) % kSlots);
  for (int probe = 0; stats[h].fn && stats[h].fn != fn; ++probe) {
    if (probe == kSlots) return;  // table full: this region goes uncounted
    h = (h + 1) % kSlots;
  }
  struct region_stats* s = &stats[h];
  s->fn = fn;
  s->calls++;
  s->total += t1 - t0;
  if (c.finish[1] > 0) {  // a team of 2 (or more: threads 0 and 1 only)
    if (c.finish[1] > c.finish[0])
      s->wait0 += c.finish[1] - c.finish[0];
    else
      s->wait1 += c.finish[0] - c.finish[1];
    s->late1 += c.start[1] - c.start[0];
  }
}
