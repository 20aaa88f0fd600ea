#!/usr/bin/env bash
# torch_vae_side_by_side.sh — optional measuring aid (never run by tests or CI): one full vae training step
# (REFERENCE.md "vae": zero grad, forward, MSE + 1e-4 KL, backward, AdamW) timed in the same session for ours
# (bench_train_vae) and PyTorch (torch_ref.py's own vae_case step, --best environment: OpenBLAS SkylakeX +
# tcmalloc), B in {32, 256} x T in {64, 128}. Prints per config: wall ms (median) and process CPU ms per step
# (median; the robust figure on a shared VM, where wall time mostly measures other people's jobs), GFLOP/s
# (torch_ref's FLOP count), % of this host's measured FMA peak (peak_GFLOP/s), and the ratio torch/ours; plus the
# load average.
# Both sides time the same way, torch_ref.py's protocol: one model per config, --warmup untimed steps (default 3,
# torch_ref.py's; PyTorch's first is its FLOP-counting step), then --steps timed steps (default 5): their median.
# (Until session 42 ours was the median of 5 separate models' second steps: bench/RESULTS.md.)
#
# Usage: bash bench/torch_vae_side_by_side.sh [--build-dir DIR] [--threads 1,2] [--configs 32x64,256x64,...]
#                                             [--steps N] [--warmup N] [--official]
#   --official also runs `torch_ref.py --best --suite vae` itself (wall-clock medians exactly as REFERENCE.md).
#   TORCH_REF=path/to/torch_ref.py (default /work/shared/anchor/torch_ref.py)
#   T2M_OPENBLAS_ROOT=DIR  use OpenBLAS/tcmalloc unpacked under DIR (`apt-get download libopenblas0-openmp
#                          libtcmalloc-minimal4; dpkg -x <deb> DIR`) when they are not installed system-wide.
set -euo pipefail
REPO="$(cd "$(dirname "$0")/.." && pwd)"
BUILD_DIR="$REPO/build"
THREADS="1,2"
CONFIGS="32x64,256x64,32x128,256x128"
STEPS=5
WARMUP=3
OFFICIAL=0
while [ $# -gt 0 ]; do
  case "$1" in
    --build-dir) BUILD_DIR="$2"; shift ;;
    --threads) THREADS="$2"; shift ;;
    --configs) CONFIGS="$2"; shift ;;
    --steps) STEPS="$2"; shift ;;
    --warmup) WARMUP="$2"; shift ;;
    --official) OFFICIAL=1 ;;
    -h|--help) sed -n 2,18p "$0"; exit 0 ;;
    *) echo "torch_vae_side_by_side.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
  shift
done
TORCH_REF="${TORCH_REF:-/work/shared/anchor/torch_ref.py}"
BENCH="$BUILD_DIR/bench_train_vae"
[ -x "$BENCH" ] || { echo "torch_vae_side_by_side.sh: $BENCH not built (cmake --build $BUILD_DIR --target bench_train_vae)" >&2; exit 1; }
[ -f "$TORCH_REF" ] || { echo "torch_vae_side_by_side.sh: $TORCH_REF not found" >&2; exit 1; }
source "$REPO/bench/torch_env.sh"
torch_best_env torch_vae_side_by_side.sh
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT


filter=""
for c in ${CONFIGS//,/ }; do filter="$filter|B:${c%x*}/T:${c#*x}/"; done
filter="${filter#|}"
time_both_sides vae "$BENCH" "$filter" "$CONFIGS" "$THREADS" "$STEPS" "$WARMUP" "$TORCH_REF" "$TMP"
/usr/bin/python3 - "$TMP" "$THREADS" <<'PY'
import json, statistics, sys
tmp, threads = sys.argv[1], [int(t) for t in sys.argv[2].split(",")]
torch = {}
for line in open(f"{tmp}/torch.txt"):
    _, b, t, th, wall, cpu, gf, _best = line.split()
    torch[(int(b), int(t), int(th))] = (float(wall), float(cpu), float(gf))
print("%-16s %3s | %9s %9s %8s %6s | %9s %9s %8s | %10s %9s" % ("config", "thr", "ours ms", "ours cpu", "GFLOP/s",
      "%peak", "torch ms", "torch cpu", "GFLOP/s", "ratio wall", "ratio cpu"))
for th in threads:
    runs = {}
    for r in json.load(open(f"{tmp}/ours_{th}.json"))["benchmarks"]:
        if r.get("run_type") != "iteration":
            continue
        b, t = int(r["name"].split("B:")[1].split("/")[0]), int(r["name"].split("T:")[1].split("/")[0])
        runs.setdefault((b, t), []).append(r)
    for (b, t), rs in runs.items():
        # one run per config: T2M_BENCH_STEPS timed steps of one model after the warm-up (bench/lib/step_timer.h)
        ms = statistics.median(r["median_ms"] for r in rs)
        cpu = statistics.median(r["median_cpu_ms"] for r in rs)
        gf = statistics.median(r["GFLOP/s"] * r["ms"] / r["median_ms"] for r in rs)  # per median step, as torch's
        tw, tc, tg = torch.get((b, t, th), (float("nan"),) * 3)
        pk = statistics.median(r["peak_GFLOP/s"] for r in rs)
        print("%-16s %3d | %9.1f %9.1f %8.1f %5.0f%% | %9.1f %9.1f %8.1f | %9.2fx %8.2fx" % (
            f"vae B{b} T{t}", th, ms, cpu, gf, 100 * gf / pk, tw, tc, tg, tw / ms, tc / cpu))
PY
if [ "$OFFICIAL" = 1 ]; then
  echo "# official: torch_ref.py --best --suite vae --threads $THREADS"
  "${TORCH_ENV[@]}" /usr/bin/python3 "$TORCH_REF" --suite vae --threads "$THREADS" --no-profile
fi
