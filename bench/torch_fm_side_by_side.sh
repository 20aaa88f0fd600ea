#!/usr/bin/env bash
# torch_fm_side_by_side.sh — optional measuring aid (never run by tests or CI): one full fm training step
# (REFERENCE.md "fm": zero grad, x_t of Eq 14, forward, Eq 15 loss, backward, AdamW) timed in the same session for
# ours (bench_train_fm) and PyTorch (torch_ref.py's own fm_case step, --best environment: OpenBLAS SkylakeX +
# tcmalloc). Configs fm-small B{32,256} x Tm{8,16}, fm-paper B32 Tm8, B32 Tm16, B256 Tm8. Prints per config: wall
# ms (median) and process CPU ms per step (median; the robust figure on a shared VM, where wall time mostly measures
# other people's jobs), GFLOP/s (torch_ref's FLOP count), % of this host's FMA peak (the benchmark's peak_GFLOP/s
# counter, measured: bench/lib/fma_peak.h), and the ratios torch/ours (> 1: ours faster); the best (minimum) wall
# time of each side and their ratio, the figure least disturbed by other VMs (noise only adds time); then the
# host's peak and the step's FLOP bound: torch's time over the time the step's FLOPs alone take at that peak, i.e.
# the ratio ours would read if every FLOP ran at the peak and nothing else took time (a target above it cannot be
# met on this host with these FLOPs); plus the load average before and after.
# Both sides time the same way, torch_ref.py's protocol: one model per config, --warmup untimed steps (default 3,
# torch_ref.py's; PyTorch's first is its FLOP-counting step), then --steps timed steps (default 5): their median
# and minimum. (Until session 42 ours was the median of 5 separate models' second steps: ~3 % slower than the steady
# state at fm-paper B32 Tm16 on the Intel VM, single such steps up to 20 %; bench/RESULTS.md.)
#
# Usage: bash bench/torch_fm_side_by_side.sh [--build-dir DIR] [--threads 1,2] [--steps N] [--warmup N]
#            [--configs small:32x8,small:256x8,small:32x16,small:256x16,paper:32x8,paper:32x16,paper:256x8]
#   TORCH_REF=path/to/torch_ref.py (default /work/shared/anchor/torch_ref.py)
#   T2M_OPENBLAS_ROOT=DIR  use OpenBLAS/tcmalloc unpacked under DIR (`apt-get download libopenblas0-openmp
#                          libtcmalloc-minimal4; dpkg -x <deb> DIR`) when they are not installed system-wide.
set -euo pipefail
REPO="$(cd "$(dirname "$0")/.." && pwd)"
BUILD_DIR="$REPO/build"
THREADS="2"
CONFIGS="small:32x8,small:256x8,small:32x16,small:256x16,paper:32x8,paper:32x16,paper:256x8"
STEPS=5
WARMUP=3
while [ $# -gt 0 ]; do
  case "$1" in
    --build-dir) BUILD_DIR="$2"; shift ;;
    --threads) THREADS="$2"; shift ;;
    --configs) CONFIGS="$2"; shift ;;
    --steps) STEPS="$2"; shift ;;
    --warmup) WARMUP="$2"; shift ;;
    -h|--help) sed -n 2,22p "$0"; exit 0 ;;
    *) echo "torch_fm_side_by_side.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
  shift
done
TORCH_REF="${TORCH_REF:-/work/shared/anchor/torch_ref.py}"
BENCH="$BUILD_DIR/bench_train_fm"
[ -x "$BENCH" ] || { echo "torch_fm_side_by_side.sh: $BENCH not built (cmake --build $BUILD_DIR --target bench_train_fm)" >&2; exit 1; }
[ -f "$TORCH_REF" ] || { echo "torch_fm_side_by_side.sh: $TORCH_REF not found" >&2; exit 1; }
source "$REPO/bench/torch_env.sh"
torch_best_env torch_fm_side_by_side.sh
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT


filter=""
for c in ${CONFIGS//,/ }; do
  s="${c%%:*}"; bt="${c#*:}"
  filter="$filter|fm_$s/B:${bt%x*}/Tm:${bt#*x}/"
done
filter="${filter#|}"
time_both_sides fm "$BENCH" "$filter" "$CONFIGS" "$THREADS" "$STEPS" "$WARMUP" "$TORCH_REF" "$TMP"
/usr/bin/python3 - "$TMP" "$THREADS" <<'PY'
import json, statistics, sys
tmp, threads = sys.argv[1], [int(t) for t in sys.argv[2].split(",")]
torch = {}
for line in open(f"{tmp}/torch.txt"):
    _, size, b, tm, th, wall, cpu, gf, best = line.split()
    torch[(size, int(b), int(tm), int(th))] = (float(wall), float(cpu), float(gf), float(best))
print("%-22s %3s | %9s %9s %8s %6s | %9s %9s %8s | %10s %9s | %9s %9s %10s | %8s %7s" % ("config", "thr", "ours ms",
      "ours cpu", "GFLOP/s", "%host", "torch ms", "torch cpu", "GFLOP/s", "ratio wall", "ratio cpu", "ours best",
      "torch best", "ratio best", "peak GF", "bound"))
for th in threads:
    runs = {}
    for r in json.load(open(f"{tmp}/ours_{th}.json"))["benchmarks"]:
        if r.get("run_type") != "iteration":
            continue
        name = r["name"]
        size = "small" if "fm_small" in name else "paper"
        b, tm = int(name.split("B:")[1].split("/")[0]), int(name.split("Tm:")[1].split("/")[0])
        runs.setdefault((size, b, tm), []).append(r)
    for (size, b, tm), rs in runs.items():
        # one run per config: T2M_BENCH_STEPS timed steps of one model after the warm-up (bench/lib/step_timer.h)
        ms = statistics.median(r["median_ms"] for r in rs)
        cpu = statistics.median(r["median_cpu_ms"] for r in rs)
        gf = statistics.median(r["GFLOP/s"] * r["ms"] / r["median_ms"] for r in rs)  # per median step, as torch's
        best = min(r["min_ms"] for r in rs)
        tw, tc, tg, tb = torch.get((size, b, tm, th), (float("nan"),) * 4)
        pk = statistics.median(r["peak_GFLOP/s"] for r in rs)  # this host's FMA peak, th threads
        # bound: torch's median over the time the step's FLOPs (gf * ms, in MFLOP) take at the peak
        print(("%-22s %3d | %9.1f %9.1f %8.1f %5.0f%% | %9.1f %9.1f %8.1f | %9.2fx %8.2fx | %9.1f %9.1f %9.2fx"
               " | %8.1f %6.2fx") % (
            f"fm-{size} B{b} Tm{tm}", th, ms, cpu, gf, 100 * gf / pk, tw, tc, tg, tw / ms, tc / cpu, best, tb,
            tb / best, pk, tw * pk / (gf * ms)))
PY
