#!/usr/bin/env bash
# Installs dependencies, builds if needed, then runs the t2m binary with the given arguments.
# Usage: bash tools/run.sh bench
set -euo pipefail
cd "$(dirname "$0")/.."
# Idle OpenMP threads sleep instead of spinning: on a loaded 2-core VM spinning costs ~20 ms per parallel region.
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
bash tools/setup.sh >/dev/null
exec ./build/t2m "$@"
