#!/usr/bin/env bash
# Installs the Debian dependencies (idempotent, quiet when already installed), then configures and builds.
# Usage: bash tools/setup.sh [--sanitize] [--build-dir DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=build
SANITIZE=OFF
while [ $# -gt 0 ]; do
  case "$1" in
    --sanitize) SANITIZE=ON; BUILD_DIR=build-asan ;;
    --build-dir) BUILD_DIR="$2"; shift ;;
    *) echo "setup.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
  shift
done

PKGS=(build-essential cmake ninja-build pkg-config libeigen3-dev libcli11-dev googletest libgtest-dev libgmock-dev
      libbenchmark-dev nlohmann-json3-dev libzstd-dev zstd libmujoco-dev libqhull-dev libosmesa6-dev libegl-dev ffmpeg)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO=sudo
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

JOBS=$(nproc)
if [ ! -f "$BUILD_DIR/build.ninja" ]; then
  LAUNCHER=()
  command -v ccache >/dev/null && LAUNCHER=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release -DT2M_SANITIZE="$SANITIZE" "${LAUNCHER[@]}" >/dev/null
fi
cmake --build "$BUILD_DIR" -j "$JOBS"
