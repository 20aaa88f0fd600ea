# torch_env.sh — sourced by the bench/torch_*side_by_side.sh scripts (never run by tests or CI): the environment of
# torch_ref.py --best (OpenBLAS with OPENBLAS_CORETYPE=SkylakeX, tcmalloc preloaded) as the array TORCH_ENV, to
# run as "${TORCH_ENV[@]}" python3 ...; ANCHOR_REEXEC=1 keeps torch_ref.py from re-executing itself.
# OpenBLAS/tcmalloc come from the system (libopenblas0-openmp, libtcmalloc-minimal4) or, when they are not
# installed, from T2M_OPENBLAS_ROOT (`apt-get download libopenblas0-openmp libtcmalloc-minimal4; dpkg -x <deb> DIR`).
# Usage: source bench/torch_env.sh; torch_best_env SCRIPT_NAME   (prints an error and exits 1 when missing);
# then time_both_sides (below) for the fm / vae scripts.
torch_best_env() {
  local lib=/usr/lib/x86_64-linux-gnu root=""
  if [ -d "$lib/openblas-openmp" ] && [ -f "$lib/libtcmalloc_minimal.so.4" ]; then
    root=""
  elif [ -n "${T2M_OPENBLAS_ROOT:-}" ]; then
    root="$T2M_OPENBLAS_ROOT"
  else
    echo "$1: OpenBLAS (libopenblas0-openmp) or tcmalloc not installed; set T2M_OPENBLAS_ROOT" >&2
    exit 1
  fi
  TORCH_ENV=(env ANCHOR_REEXEC=1 LD_LIBRARY_PATH="$root$lib/openblas-openmp" OPENBLAS_CORETYPE=SkylakeX
             LD_PRELOAD="$root$lib/libtcmalloc_minimal.so.4")
}

# "FMA_GFLOPS TRIAD_GBPS": the FMA peak and the memory bandwidth (STREAM triad) on THREADS threads right now, by the
# t2m binary next to BENCH (0.4 s); "- -" when it is not built.
host_peak() {
  local t2m
  t2m="$(dirname "$1")/t2m"
  [ -x "$t2m" ] || { echo "- -"; return; }
  "$t2m" bench --peak --bandwidth --threads "$2" | awk '{v[$1] = $5} END {print v["fma_peak"], v["mem_triad"]}'
}

# One line for the three probes around a config's two sides: "FMA a / b / c GFLOP/s, triad d / e / f GB/s".
probe_line() {
  local -a p0 p1 p2
  read -r -a p0 <<< "$1"
  read -r -a p1 <<< "$2"
  read -r -a p2 <<< "$3"
  echo "FMA ${p0[0]} / ${p1[0]} / ${p2[0]} GFLOP/s, triad ${p0[1]} / ${p1[1]} / ${p2[1]} GB/s"
}

# Runs config number N's two sides back to back, OURS_FN first when N is even and TORCH_FN first otherwise (each a
# command that times one side), probes the host before, between and after (host_peak on BENCH's t2m, THREADS
# threads) and prints one line about it labelled LABEL.
# Usage: back_to_back N LABEL BENCH THREADS OURS_FN TORCH_FN
back_to_back() {
  local n="$1" label="$2" bench="$3" th="$4" first="$5" second="$6" first_name=ours p0 p1 p2
  if (( n % 2 )); then first="$6" second="$5" first_name=torch; fi
  p0="$(host_peak "$bench" "$th")"
  "$first"
  p1="$(host_peak "$bench" "$th")"
  "$second"
  p2="$(host_peak "$bench" "$th")"
  echo "# $label ($th threads, $first_name first), host before / between / after: $(probe_line "$p0" "$p1" "$p2")"
}

# Times both sides of the fm or vae side by side with torch_ref.py's protocol, for each thread count: ours
# (BENCH, the configs picked by FILTER; bench/lib/step_timer.h's T2M_BENCH_WARMUP / T2M_BENCH_STEPS) into
# OUT/ours_<threads>.json, PyTorch (bench/torch_steps.py KIND CONFIGS, after torch_best_env) appended to OUT/torch.txt.
# The two sides of a config run back to back, one process each, ours first for the 1st, 3rd, ... config and
# PyTorch first for the others: this VM's speed drifts over minutes (its second vCPU at times gives a quarter of its
# FMA rate, session 44), and a config's two measurements seconds apart see the same machine far more often than
# all of ours followed by all of PyTorch's did. FILTER holds one '|'-separated alternative per CONFIGS entry, in
# the same order.
# Around each side the host's FMA peak and memory bandwidth are probed (`t2m bench --peak --bandwidth`, 0.4 s) and
# printed as a record of its state: the FMA probe flags a vCPU giving a fraction of its rate (145 instead of 234
# GFLOP/s on 2 threads), the triad memory contention (35-43 against ~71 GB/s when quiet); neither separated the fast
# and slow phases of a 6-pair test (bench/RESULTS.md, session 44), so several rounds are still needed.
# Usage: time_both_sides KIND BENCH FILTER CONFIGS THREADS(1,2) STEPS WARMUP TORCH_REF OUT
# (STEPS and WARMUP must be positive integers: else one message and exit 2.)
time_both_sides() {
  local kind="$1" bench="$2" filter="$3" configs="$4" threads="$5" steps="$6" warmup="$7" torch_ref="$8" out="$9"
  [[ "$warmup" =~ ^[1-9][0-9]*$ && "$steps" =~ ^[1-9][0-9]*$ ]] || {
    echo "$(basename "$0"): --warmup and --steps take positive integers (got '$warmup', '$steps')" >&2; exit 2; }
  local steps_py th i
  local -a filters cfgs ours_cmd torch_cmd
  IFS='|' read -r -a filters <<< "$filter"
  IFS=',' read -r -a cfgs <<< "$configs"
  [ "${#filters[@]}" -eq "${#cfgs[@]}" ] || {
    echo "$(basename "$0"): ${#filters[@]} benchmark filters for ${#cfgs[@]} configs" >&2; exit 2; }
  steps_py="$(dirname "${BASH_SOURCE[0]}")/torch_steps.py"
  echo "# load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
  for th in ${threads//,/ }; do
    echo "# ours:  OMP_NUM_THREADS=$th T2M_BENCH_WARMUP=$warmup T2M_BENCH_STEPS=$steps $bench --benchmark_filter=<config>"
    echo "# torch: ${TORCH_ENV[*]} /usr/bin/python3 bench/torch_steps.py <torch_ref> $th $steps $warmup $kind <config>"
    echo "# each config's two sides back to back, alternating which goes first"
    for i in "${!cfgs[@]}"; do
      ours_cmd=(env OMP_NUM_THREADS="$th" T2M_BENCH_WARMUP="$warmup" T2M_BENCH_STEPS="$steps" "$bench"
                --benchmark_filter="${filters[$i]}" --benchmark_format=json)
      torch_cmd=("${TORCH_ENV[@]}" /usr/bin/python3 "$steps_py" "$torch_ref" "$th" "$steps" "$warmup" "$kind"
                 "${cfgs[$i]}")
      back_to_back "$i" "${cfgs[$i]}" "$bench" "$th" time_ours_side time_torch_side
    done
    # One Google Benchmark JSON per thread count, as a single run would have written it.
    /usr/bin/python3 - "$out" "$th" "${#cfgs[@]}" <<'PY'
import json, sys
out, th, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
runs = [json.load(open(f"{out}/ours_{th}_{i}.json")) for i in range(n)]
json.dump(dict(runs[0], benchmarks=[b for r in runs for b in r["benchmarks"]]), open(f"{out}/ours_{th}.json", "w"))
PY
  done
  echo "# load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
}
# time_both_sides's two sides (they read its locals ours_cmd / torch_cmd, out, th, i: bash scoping is dynamic).
time_ours_side() { "${ours_cmd[@]}" > "$out/ours_${th}_$i.json" 2> /dev/null; }
time_torch_side() { "${torch_cmd[@]}" >> "$out/torch.txt"; }
