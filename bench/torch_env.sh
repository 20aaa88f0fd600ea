# torch_env.sh — sourced by the bench/torch_*side_by_side.sh scripts (never run by tests or CI): the environment of
# torch_ref.py --best (OpenBLAS with OPENBLAS_CORETYPE=SkylakeX, tcmalloc preloaded) as the array TORCH_ENV, to
# run as "${TORCH_ENV[@]}" python3 ...; ANCHOR_REEXEC=1 keeps torch_ref.py from re-executing itself.
# OpenBLAS/tcmalloc come from the system (libopenblas0-openmp, libtcmalloc-minimal4) or, when they are not
# installed, from T2M_OPENBLAS_ROOT (`apt-get download libopenblas0-openmp libtcmalloc-minimal4; dpkg -x <deb> DIR`).
# Usage: source bench/torch_env.sh; torch_best_env SCRIPT_NAME   (prints an error and exits 1 when missing)
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
