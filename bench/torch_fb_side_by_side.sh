#!/usr/bin/env bash
# torch_fb_side_by_side.sh — optional measuring aid (never run by tests): one FB agent training update, ours
# (bench_train_fb) and PyTorch's (../shared/anchor/torch_ref.py --suite fb, --best = OpenBLAS SkylakeX +
# tcmalloc) in the same session, same configs (fb-w256 B256 and fb-w1024 B1024, parts fb / actor / both), same
# thread count; prints ms per step (wall, the median step on both sides), our process CPU ms, GFLOP/s with the
# anchor's FLOP count, % of this host's measured per-core FMA peak, and the speed-up torch_ms / ours_ms. The
# machine load (uptime) is printed before and after: with other jobs running, wall times are inflated for both.
# Each group of configs (fb-w256 B256, fb-w1024 B1024) is timed on both sides back to back, one process each,
# alternating which side goes first (the VM's speed drifts over minutes), and the host's FMA peak and memory
# bandwidth probed around each side (bench/torch_env.sh host_peak) are printed.
#
# --mode cpu: instead of torch_ref.py's wall-clock loop, time torch's fb_case with bench/torch_fb_cputime.py by
# process CPU time per step (median) and compare it with our cpu_ms (mean): the fairer number on a loaded machine.
#
# Usage: bash bench/torch_fb_side_by_side.sh [--build-dir DIR] [--threads N] [--only REGEX] [--mode wall|cpu]
#   TORCH_REF=path/to/torch_ref.py (default /work/shared/anchor/torch_ref.py)
#   T2M_OPENBLAS_ROOT=DIR  OpenBLAS (openmp) and tcmalloc unpacked under DIR (dpkg -x libopenblas0-openmp*.deb
#                          libtcmalloc-minimal4*.deb DIR) when not installed system-wide; --best needs them.
#   OMP_WAIT_POLICY is passed through to both (passive avoids spin-wait collapse on an oversubscribed machine).
set -euo pipefail
REPO="$(cd "$(dirname "$0")/.." && pwd)"
BUILD_DIR="$REPO/build"
THREADS=2
ONLY="fb-w256 B256|fb-w1024 B1024"
MODE=wall
while [ $# -gt 0 ]; do
  case "$1" in
    --build-dir) BUILD_DIR="$2"; shift ;;
    --threads) THREADS="$2"; shift ;;
    --only) ONLY="$2"; shift ;;
    --mode) MODE="$2"; shift ;;
    -h|--help) sed -n 2,19p "$0"; exit 0 ;;
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
source "$REPO/bench/torch_env.sh"
torch_best_env torch_fb_side_by_side.sh
echo "# load before: $(uptime)"
echo "# ours: OMP_NUM_THREADS=$THREADS $BENCH --benchmark_filter=<group>"
if [ "$MODE" = cpu ]; then
  echo "# torch (--best environment): bench/torch_fb_cputime.py --threads $THREADS --configs <group's w:B:part>"
else
  echo "# torch (--best environment): $TORCH_REF --suite fb --only <group> --threads $THREADS --no-profile --json <tmp>"
fi
# Each group of --only ('fb-w256 B256', ...) is timed on both sides back to back, alternating which goes first: the
# VM's speed drifts over minutes, a group's two measurements seconds apart see the same machine (session 44).
IFS='|' read -r -a GROUPS_ <<< "$ONLY"
ours() {  # the group $group, output index $i
  OMP_NUM_THREADS="$THREADS" "$BENCH" --benchmark_filter="$group" --benchmark_format=json \
    --benchmark_out="$TMP/ours_$i.json" --benchmark_out_format=json > /dev/null
}
torch() {  # the group $group, output index $i
  if [ "$MODE" = cpu ]; then  # torch_fb_cputime.py configs w:B:part
    local cfg
    cfg="$(echo "$group" | sed -E 's/fb-w([0-9]+) B([0-9]+)/\1:\2/')"
    "${TORCH_ENV[@]}" TORCH_REF="$TORCH_REF" /usr/bin/python3 "$REPO/bench/torch_fb_cputime.py" \
      --threads "$THREADS" --configs "$cfg:fb,$cfg:actor,$cfg:both" >> "$TMP/torch_cpu.txt"
  else
    "${TORCH_ENV[@]}" /usr/bin/python3 "$TORCH_REF" --suite fb --only "$group" --threads "$THREADS" --no-profile \
      --json "$TMP/torch_$i.json" >> "$TMP/torch.txt" 2>&1
  fi
}
echo "# each group's two sides back to back, alternating which goes first"
for i in "${!GROUPS_[@]}"; do
  group="${GROUPS_[$i]}"
  back_to_back "$i" "$group" "$BENCH" "$THREADS" ours torch
done
echo "# load after: $(uptime)"
/usr/bin/python3 - "$MODE" "$TMP" "${#GROUPS_[@]}" <<'PY'
import json, sys
mode, tmp, ngroups = sys.argv[1], sys.argv[2], int(sys.argv[3])
ours = {}
for i in range(ngroups):
    ours.update({b["name"].split("/")[0]: b for b in json.load(open(f"{tmp}/ours_{i}.json"))["benchmarks"]})
torch = {}
if mode == "cpu":
    for line in open(f"{tmp}/torch_cpu.txt"):
        f = line.split()
        torch[" ".join(f[:3])] = {"cpu": float(f[4]), "ms": float(f[5])}
else:
    for i in range(ngroups):
        for r in json.load(open(f"{tmp}/torch_{i}.json"))["runs"][-1]["results"]:
            torch[r["name"]] = {"ms": r["median_ms"], "gflops": r["gflops"]}
key = "cpu" if mode == "cpu" else "ms"
print(f"compared by {'process CPU ms per step' if mode == 'cpu' else 'wall ms per step'}")
print(f"{'config':22s} {'thr':>3s} {'ours ms':>9s} {'ours cpu':>9s} {'GF/s(cpu)':>9s} {'%peak':>6s} "
      f"{'torch ms':>9s} {'torch cpu':>9s} {'speed-up':>8s}")
for name, b in ours.items():
    t = torch.get(name, {})
    flops = b["GFLOP/s"] * b["ms"] * 1e-3  # GFLOP per step
    gf_cpu = flops / (b["cpu_ms"] * 1e-3)  # per CPU-second: per busy core
    wall = b.get("median_ms", b["ms"])  # the median step, as torch_ref.py reports its own
    mine = b["cpu_ms"] if mode == "cpu" else wall
    theirs = t.get(key, float("nan"))
    cell = lambda v: f"{v:9.1f}" if v is not None else f"{'-':>9s}"  # torch's CPU time: --mode cpu only
    print(f"{name:22s} {int(b['threads']):3d} {wall:9.1f} {b['cpu_ms']:9.1f} {gf_cpu:9.1f} "
          f"{100 * gf_cpu / (b['peak_GFLOP/s'] / b['threads']):6.1f} {cell(t.get('ms'))} {cell(t.get('cpu'))} "
          f"{theirs / mine:7.2f}x")
PY
