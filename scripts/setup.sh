#!/usr/bin/env bash
# ovo set-up: installs the Debian packages that are missing, configures and builds into build/,
# then runs what was asked:
#   scripts/setup.sh run    simulate the default vineyard sequence, run ovo on it, show the metrics
#   scripts/setup.sh test   build everything and run the whole test suite (ctest)
#   scripts/setup.sh build  only install and build
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
MODE=${1:-build}
JOBS=${OVO_JOBS:-$(nproc)}

PACKAGES=(build-essential cmake ninja-build ccache pkg-config
  libeigen3-dev libceres-dev libsuitesparse-dev libopencv-dev
  pocl-opencl-icd ocl-icd-opencl-dev opencl-headers
  libgtest-dev libgmock-dev libbenchmark-dev libopengv-dev
  libcli11-dev nlohmann-json3-dev libspdlog-dev libfmt-dev libyaml-cpp-dev libtbb-dev zlib1g-dev
  xvfb xauth)
# Only the test command needs a browser (report.html is rendered in headless Chromium; the test
# skips without it).
if [ "$MODE" = test ]; then PACKAGES+=(chromium); fi

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "ovo setup: installing ${missing[*]}"
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# PoCL (CPU OpenCL) needs a writable kernel cache, or it reports no device at all.
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-${XDG_CACHE_HOME:-$HOME/.cache}/ovo-pocl}
mkdir -p "$POCL_CACHE_DIR"

BUILD=${OVO_BUILD_DIR:-$ROOT/build}
if [ ! -f "$BUILD/build.ninja" ]; then
  cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release
fi
cmake --build "$BUILD" -j "$JOBS"

case "$MODE" in
  build) ;;
  run)
    # The built-in default: the simulated vineyard (two rows joined by a headland U-turn).
    OUT=${OVO_DEMO_OUT:-$ROOT/out/demo}
    SCENARIO=${OVO_DEMO_SCENARIO:-$ROOT/configs/sim/vineyard_row.yaml}
    echo "ovo: simulating $(basename "$SCENARIO" .yaml) into $OUT/data"
    "$BUILD/ovo" simulate --config "$SCENARIO" --out "$OUT/data" --overwrite
    echo "ovo: running the window estimator"
    "$BUILD/ovo" run --dataset "$OUT/data" --estimator "${OVO_DEMO_ESTIMATOR:-window}" --out "$OUT/run"
    echo "ovo: trajectory, metrics and report in $OUT/run"
    ;;
  test)
    cd "$BUILD"
    ctest --output-on-failure -j "$JOBS" --timeout 900
    ;;
  *)
    echo "usage: scripts/setup.sh [build|run|test]" >&2
    exit 2
    ;;
esac
