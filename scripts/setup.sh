#!/usr/bin/env bash
# ovo set-up: installs the Debian packages that are missing, configures and builds into build/,
# then runs what was asked:
#   scripts/setup.sh run    build the ovo command only, simulate the default vineyard sequence, run
#                           ovo on it and show a short summary (the first result in minutes)
#   scripts/setup.sh test   build everything and run the whole test suite (ctest)
#   scripts/setup.sh build  only install and build everything
#   scripts/setup.sh ros    also install Debian's ROS 1 packages and build the node (build/ros/ovo_ros)
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
MODE=${1:-build}
JOBS=${OVO_JOBS:-$(nproc)}
case "$MODE" in
  build | run | test | ros) ;;
  *)
    echo "usage: scripts/setup.sh [build|run|test|ros]" >&2
    exit 2
    ;;
esac

PACKAGES=(build-essential cmake ninja-build ccache pkg-config
  libeigen3-dev libceres-dev libsuitesparse-dev libopencv-dev
  pocl-opencl-icd ocl-icd-opencl-dev opencl-headers
  libgtest-dev libgmock-dev libbenchmark-dev libopengv-dev
  libcli11-dev nlohmann-json3-dev libspdlog-dev libfmt-dev libyaml-cpp-dev libtbb-dev zlib1g-dev
  librosbag-storage-dev libsensor-msgs-dev libsqlite3-dev libzstd-dev liblz4-dev libbz2-dev
  xvfb xauth)
# Only the test command needs a browser (report.html is rendered in headless Chromium; the test
# skips without it).
if [ "$MODE" = test ]; then PACKAGES+=(chromium); fi
# The ROS 1 node (ros/) and its end-to-end test (a master, roslaunch, rosbag play and record):
# Debian 12's ROS 1 packages, about 110 small packages.
ROS_PACKAGES=(libroscpp-dev libtf2-ros-dev libtf2-msgs-dev libnav-msgs-dev libgeometry-msgs-dev
  libdiagnostic-msgs-dev ros-core-dev python3-roslaunch python3-rosbag python3-rostopic)
if [ "$MODE" = test ] || [ "$MODE" = ros ]; then PACKAGES+=("${ROS_PACKAGES[@]}"); fi
if [ "$MODE" = ros ]; then PACKAGES+=(rviz); fi  # the viewer (Qt, OGRE): not for the tests

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "ovo setup: installing ${#missing[@]} Debian packages (and what they need): ${missing[*]}"
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
# A build configured before ROS was installed does not have the node: configure again.
if [ -f "$BUILD/build.ninja" ] && { [ "$MODE" = test ] || [ "$MODE" = ros ]; } &&
  ! grep -q "ovo_ros" "$BUILD/build.ninja"; then
  cmake "$BUILD" >"$BUILD/configure.log" 2>&1 || { cat "$BUILD/configure.log" >&2; exit 1; }
fi
if [ ! -f "$BUILD/build.ninja" ]; then
  echo "ovo setup: configuring $BUILD (Release)"
  mkdir -p "$BUILD"
  cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release >"$BUILD/configure.log" 2>&1 ||
    { cat "$BUILD/configure.log" >&2; exit 1; }
fi

case "$MODE" in
  run)
    # Only the command (not the tests and benchmarks): ninja's [done/total] line is the progress.
    echo "ovo setup: building the ovo command ($JOBS jobs; about 5 minutes on 2 idle cores the first time)"
    cmake --build "$BUILD" -j "$JOBS" --target ovo
    # The built-in default: the simulated vineyard (two rows joined by a headland U-turn).
    OUT=${OVO_DEMO_OUT:-$ROOT/out/demo}
    SCENARIO=${OVO_DEMO_SCENARIO:-$ROOT/configs/sim/vineyard_row.yaml}
    echo "ovo: simulating $(basename "$SCENARIO" .yaml) into $OUT/data"
    "$BUILD/ovo" simulate --config "$SCENARIO" --out "$OUT/data" --overwrite
    echo "ovo: running the ${OVO_DEMO_ESTIMATOR:-window} estimator on it"
    "$BUILD/ovo" run --dataset "$OUT/data" --estimator "${OVO_DEMO_ESTIMATOR:-window}" --out "$OUT/run"
    ;;
  build)
    cmake --build "$BUILD" -j "$JOBS"
    ;;
  ros)
    cmake --build "$BUILD" -j "$JOBS" --target ovo ovo_ros
    echo "ovo setup: the node is $BUILD/ros/ovo_ros (README: On a robot: the ROS 1 node)"
    ;;
  test)
    cmake --build "$BUILD" -j "$JOBS"
    cd "$BUILD"
    ctest --output-on-failure -j "$JOBS" --timeout 900
    ;;
esac
