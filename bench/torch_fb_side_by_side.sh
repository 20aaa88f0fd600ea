#!/usr/bin/env bash
# torch_fb_side_by_side.sh — optional measuring aid (never run by tests): one FB agent training update, ours
# (bench_train_fb) and PyTorch's (../shared/anchor/torch_ref.py --suite fb, --best = OpenBLAS SkylakeX +
# tcmalloc) in the same session, same configs (fb-w256 B256 and fb-w1024 B1024, parts fb / actor / both), same
# thread count; prints ms per step (wall, median for torch, mean for ours), our process CPU ms, GFLOP/s with the
# anchor's FLOP count, % of the 220 GFLOP/s/core peak, and the speed-up torch_ms / ours_ms. The machine load
# (uptime) is printed before and after: with other jobs running, wall times are inflated for both.
#
# Usage: bash bench/torch_fb_side_by_side.sh [--build-dir DIR] [--threads N] [--only REGEX]
#   TORCH_REF=path/to/torch_ref.py (default /work/shared/anchor/torch_ref.py)
#   T2M_OPENBLAS_ROOT=DIR  OpenBLAS (openmp) and tcmalloc unpacked under DIR (dpkg -x libopenblas0-openmp*.deb
#                          libtcmalloc-minimal4*.deb DIR) when not installed system-wide; --best needs them.
#   OMP_WAIT_POLICY is passed through to both (passive avoids spin-wait collapse on an oversubscribed machine).
set -euo pipefail
REPO="$(cd "$(dirname "$0")/.." && pwd)"
BUILD_DIR="$REPO/build"
THREADS=2
ONLY="fb-w256 B256|fb-w1024 B1024"
while [ $# -gt 0 ]; do
  case "$1" in
    --build-dir) BUILD_DIR="$2"; shift ;;
    --threads) THREADS="$2"; shift ;;
    --only) ONLY="$2"; shift ;;
    -h|--help) sed -n 2,15p "$0"; exit 0 ;;
    *) echo "torch_fb_side_by_side.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
  shift
done
TORCH_REF="${TORCH_REF:-/work/shared/anchor/torch_ref.py}"
BENCH="$BUILD_DIR/bench_train_fb"
[ -x "$BENCH" ] || { echo "torch_fb_side_by_side.sh: $BENCH not built (cmake --build $BUILD_DIR --target bench_train_fb)" >&2; exit 1; }
[ -f "$TORCH_REF" ] || { echo "torch_fb_side_by_side.sh: $TORCH_REF not found" >&2; exit 1; }
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT

echo "# load before: $(uptime)"
echo "# ours: OMP_NUM_THREADS=$THREADS $BENCH --benchmark_filter='$ONLY'"
OMP_NUM_THREADS="$THREADS" "$BENCH" --benchmark_filter="$ONLY" --benchmark_format=json --benchmark_out="$TMP/ours.json" \
  --benchmark_out_format=json > /dev/null

# torch_ref --only takes comma-separated substrings
TORCH_ONLY="$(echo "$ONLY" | tr '|' ',')"
TORCH_ARGS=(--suite fb --only "$TORCH_ONLY" --threads "$THREADS" --no-profile --json "$TMP/torch.json")
LIB=/usr/lib/x86_64-linux-gnu
if [ -d "$LIB/openblas-openmp" ] && [ -f "$LIB/libtcmalloc_minimal.so.4" ]; then
  echo "# torch: /usr/bin/python3 $TORCH_REF --best ${TORCH_ARGS[*]}"
  /usr/bin/python3 "$TORCH_REF" --best "${TORCH_ARGS[@]}" > "$TMP/torch.txt" 2>&1
elif [ -n "${T2M_OPENBLAS_ROOT:-}" ]; then
  R="$T2M_OPENBLAS_ROOT$LIB"
  echo "# torch: --best equivalent (OpenBLAS SkylakeX + tcmalloc from $T2M_OPENBLAS_ROOT) ${TORCH_ARGS[*]}"
  ANCHOR_REEXEC=1 LD_LIBRARY_PATH="$R/openblas-openmp" OPENBLAS_CORETYPE=SkylakeX LD_PRELOAD="$R/libtcmalloc_minimal.so.4" \
    /usr/bin/python3 "$TORCH_REF" "${TORCH_ARGS[@]}" > "$TMP/torch.txt" 2>&1
else
  echo "torch_fb_side_by_side.sh: OpenBLAS (libopenblas0-openmp) or tcmalloc not installed; set T2M_OPENBLAS_ROOT" >&2
  exit 1
fi
echo "# load after: $(uptime)"

/usr/bin/python3 - "$TMP/ours.json" "$TMP/torch.json" <<'PY'
import json, sys
ours = {}
for b in json.load(open(sys.argv[1]))["benchmarks"]:
    ours[b["name"].split("/")[0]] = b
torch = {r["name"]: r for r in json.load(open(sys.argv[2]))["runs"][-1]["results"]}
print(f"{'config':22s} {'thr':>3s} {'ours ms':>9s} {'ours cpu':>9s} {'GFLOP/s':>8s} {'%peak':>6s} "
      f"{'torch ms':>9s} {'GFLOP/s':>8s} {'speed-up':>8s}")
for name, b in ours.items():
    t = torch.get(name)
    tm = t["median_ms"] if t else float("nan")
    tg = t["gflops"] if t else float("nan")
    print(f"{name:22s} {int(b['threads']):3d} {b['ms']:9.1f} {b['cpu_ms']:9.1f} {b['GFLOP/s']:8.1f} "
          f"{b['%peak']:6.1f} {tm:9.1f} {tg:8.1f} {tm / b['ms']:7.2f}x")
PY
