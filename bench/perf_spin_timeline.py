#!/usr/bin/env python3
"""perf_spin_timeline.py — what the other thread was doing while one OpenMP thread waited in libgomp.

Usage (a 2-thread benchmark; any binary):
    OMP_NUM_THREADS=2 perf record -g -o run.data build/bench_train_vae --benchmark_filter='B:32/T:64' \\
        --benchmark_min_time=6
    perf script -i run.data -F tid,time,ip,sym,dso > run.script
    python3 bench/perf_spin_timeline.py run.script [TOP]

For the two busiest threads, every sample whose top frame is in libgomp (spinning or at a barrier) is matched to
the other thread's nearest later sample; the table counts what that thread was executing (top frame, and the first
t2m:: caller outside the GEMM internals when call chains are present). Waiting while the other thread is in the
GEMM micro-kernel means load imbalance inside a GEMM; waiting while it runs an elementwise op means a serial section
or an imbalanced op.
"""
import bisect
import collections
import re
import sys


def parse(path):
    samples, cur = [], None
    head = re.compile(r'^\s*(\d+)\s+([\d.]+):\s*(?:[0-9a-f]+\s+(.*)\((.*)\))?\s*$')
    frame = re.compile(r'^\s+([0-9a-f]+)\s+(.*)\((.*)\)\s*$')
    for line in open(path):
        m = head.match(line)
        if m:
            cur = [int(m.group(1)), float(m.group(2)), []]
            samples.append(cur)
            if m.group(3) is not None:  # no call chains: the frame is on the header line
                cur[2].append('<gomp>' if 'libgomp' in m.group(4) else m.group(3).strip())
            continue
        m = frame.match(line)
        if m and cur is not None:
            cur[2].append('<gomp>' if 'libgomp' in m.group(3) else m.group(2).strip())
    return samples


def label(stack):
    skip = ('gemm_detail', 'macro_kernel', 'gemm_packed', 'gemm_run', 'gemm_small', '<gomp>', 'GOMP', 'kernel_f32',
            'pack_')
    top = stack[0] if stack else '?'
    for f in stack[1:]:
        if f.startswith('t2m::') and not any(k in f for k in skip):
            return top[:60] + ' <- ' + f[:100]
    return top[:100]


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    top_n = int(sys.argv[2]) if len(sys.argv) > 2 else 20
    samples = parse(sys.argv[1])
    counts = collections.Counter(s[0] for s in samples)
    if len(counts) < 2:
        sys.exit('perf_spin_timeline: need samples of two threads, found %d' % len(counts))
    a, b = [t for t, _ in counts.most_common(2)]
    per = {x: [s for s in samples if s[0] == x] for x in (a, b)}
    total = len(per[a]) + len(per[b])
    for me, other in ((a, b), (b, a)):
        times = [s[1] for s in per[other]]
        seen, n = collections.Counter(), 0
        for s in per[me]:
            if not s[2] or s[2][0] != '<gomp>':
                continue
            i = bisect.bisect_left(times, s[1])
            if i < len(times):
                seen[label(per[other][i][2])] += 1
                n += 1
        print('thread %d: %d libgomp samples (%.1f %% of both threads\' samples); the other thread meanwhile:'
              % (me, n, 100.0 * n / total))
        for what, k in seen.most_common(top_n):
            print('  %6d  %s' % (k, what))


if __name__ == '__main__':
    main()
