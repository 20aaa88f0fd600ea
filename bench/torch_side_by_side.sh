#!/usr/bin/env bash
# torch_side_by_side.sh — optional measuring aid (never run by tests or CI): times our float GEMM (`t2m bench`)
# and PyTorch's sgemm (torch_ref.py --best: OpenBLAS SkylakeX + tcmalloc, /usr/bin/python3) on the micro-suite
# shapes in the same session and prints both GFLOP/s (median) side by side with the ratio ours/torch.
#
# Usage: bash bench/torch_side_by_side.sh [--build-dir DIR] [--threads 1,2] [--reps N]
#   TORCH_REF=path/to/torch_ref.py (default /work/shared/anchor/torch_ref.py)
#   T2M_OPENBLAS_ROOT=DIR  use OpenBLAS/tcmalloc unpacked under DIR (e.g. `dpkg -x libopenblas0-openmp*.deb DIR`)
#                          when they are not installed system-wide; --best needs them, otherwise torch falls
#                          back to the reference BLAS and the comparison is meaningless.
set -euo pipefail
REPO="$(cd "$(dirname "$0")/.." && pwd)"
BUILD_DIR="$REPO/build"
THREADS="1,2"
REPS=20
while [ $# -gt 0 ]; do
  case "$1" in
    --build-dir) BUILD_DIR="$2"; shift ;;
    --threads) THREADS="$2"; shift ;;
    --reps) REPS="$2"; shift ;;
    -h|--help) sed -n 2,10p "$0"; exit 0 ;;
    *) echo "torch_side_by_side.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
  shift
done
TORCH_REF="${TORCH_REF:-/work/shared/anchor/torch_ref.py}"
T2M="$BUILD_DIR/t2m"
[ -x "$T2M" ] || { echo "torch_side_by_side.sh: $T2M not built (cmake --build $BUILD_DIR --target t2m)" >&2; exit 1; }
[ -f "$TORCH_REF" ] || { echo "torch_side_by_side.sh: $TORCH_REF not found" >&2; exit 1; }
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT

echo "# ours: $T2M bench --shapes micro --threads $THREADS --reps $REPS"
"$T2M" bench --shapes micro --threads "$THREADS" --reps "$REPS" | tee "$TMP/ours.txt"

TORCH_ARGS=(--suite micro --only "(out=)" --threads "$THREADS" --micro-reps "$REPS" --json "$TMP/torch.json")
source "$REPO/bench/torch_env.sh"
torch_best_env torch_side_by_side.sh
echo "# torch: ${TORCH_ENV[*]} /usr/bin/python3 $TORCH_REF ${TORCH_ARGS[*]}"
"${TORCH_ENV[@]}" /usr/bin/python3 "$TORCH_REF" "${TORCH_ARGS[@]}" > "$TMP/torch.txt" 2>&1
grep -E "^# env" "$TMP/torch.txt" || true

# torch JSON -> "MxNxK threads gflops" lines, then join with our table on (shape, threads).
/usr/bin/python3 -c '
import json, sys
for r in json.load(open(sys.argv[1]))["runs"][-1]["results"]:
    if r["name"].startswith("sgemm ") and "(out=)" in r["name"]:
        print(r["name"].split()[1], r["threads"], "%.1f" % r["gflops"])
' "$TMP/torch.json" > "$TMP/torch.lines"
echo
printf "%-18s %7s %12s %12s %14s %8s\n" "shape MxNxK" threads "ours GF/s" "ours %peak" "torch GF/s" "ratio"
awk 'NR == FNR { t[$1 " " $2] = $3; next }
     $1 ~ /^[0-9]+x[0-9]+x[0-9]+$/ && ($1 " " $2) in t {
       printf "%-18s %7s %12s %12s %14s %7.2fx\n", $1, $2, $4, $5, t[$1 " " $2], $4 / t[$1 " " $2] }' \
  "$TMP/torch.lines" "$TMP/ours.txt"
