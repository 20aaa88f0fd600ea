#!/usr/bin/env bash
# Installs dependencies, builds if needed, then runs the t2m binary with the given arguments.
# Usage: bash tools/run.sh bench
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh >/dev/null
exec ./build/t2m "$@"
