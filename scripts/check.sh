#!/usr/bin/env bash
# ovo's checks beyond the normal test suite, one subcommand each (each builds into its own folder
# beside build/, so the Release build is never touched):
#
#   scripts/check.sh sanitize [asan|tsan|all] [--subset]
#       asan: build-asan (gcc, -O1 -g, assertions on, AddressSanitizer + UndefinedBehaviorSanitizer,
#             UB not recoverable) and the whole ctest suite under it; --subset runs the fixed CI
#             subset instead (every reader, the window estimator, the runners: see SUBSET below).
#       tsan: build-tsan (ThreadSanitizer) and the threaded tests: the online pipeline, the replay,
#             the two-stage offline runner, ovo run --realtime and ovo_live_camera.
#       all (the default): both. Exit status non-zero when a build or a test fails.
#   scripts/check.sh fuzz [seconds] [target...]
#       build-fuzz (clang, libFuzzer + ASan + UBSan), then each fuzz target (all by default) for
#       `seconds` (default 60) on a corpus seeded from tests/fuzz/seeds and ../shared/data;
#       OVO_FUZZ_PARALLEL=2 runs two at a time. Prints executions, coverage and time per target;
#       a crash, hang, leak or OOM leaves its input in build-fuzz/artifacts/<target>/ (add it to
#       tests/fuzz/regressions/<target>/ once fixed).
#   scripts/check.sh soak [driving-hours] [ovo_soak options...]
#       the Release build's ovo_soak: the simulated sequence fed again and again through the
#       online pipeline (bench/soak.cpp); writes build/soak/soak.csv and soak.svg.
#   scripts/check.sh arm64 [ctest options...]
#       cross build for arm64 with Debian's cross toolchain (crossbuild-essential-arm64) and the
#       :arm64 multiarch -dev packages, then the tests under qemu-user: by default every folder's
#       but tests/apps (the end-to-end runs; `ctest -LE apps`), else the ctest options given
#       (e.g. -L io, or -R Kernels). Debian 12's arm64 -dev packages of Ceres, OpenCV and yaml-cpp
#       cannot be installed beside the amd64 ones, so the build runs in a Debian 12 (amd64) root
#       made by debootstrap (OVO_ARM64_ROOT, default build-arm64/root) holding only the arm64
#       ones, the source tree and ../shared/data mounted in it. Needs root (or sudo) for
#       debootstrap, mount and chroot. ROS 1 bags are off (OVO_WITH_ROS1=OFF: Debian 12 has no
#       arm64 librosbag-storage-dev); their tests skip. Not part of CI (about three hours on two
#       cores; in two halves: `-LE apps -I 1,0,2`, `-LE apps -I 2,0,2`, then `--compare`).
#       Without ctest options the end-to-end subset follows the tests: a short simulated row made
#       by the x86-64 build (build/, brought up to date), `ovo run` of vo, kf and window by both
#       builds on it, and each arm64 trajectory compared with the x86-64 one at the same stamps
#       (RMS of the position difference, no alignment) against ARM64_TOLERANCE_M below.
#       `scripts/check.sh arm64 --compare` builds and runs that subset alone.
#
# Environment: OVO_JOBS (parallel build jobs, default nproc), OVO_SHARED_DATA (../shared/data).
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
JOBS=${OVO_JOBS:-$(nproc)}
SHARED=${OVO_SHARED_DATA:-$ROOT/../shared/data}
SUPP=$ROOT/scripts/sanitizers
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-${XDG_CACHE_HOME:-$HOME/.cache}/ovo-pocl}
mkdir -p "$POCL_CACHE_DIR"

usage() { sed -n '2,/^set -euo/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'; }

# configure <build dir> <cmake args...>: configures once (a later call keeps the folder's cache).
configure() {
  local dir=$1
  shift
  if [ ! -f "$dir/build.ninja" ]; then cmake -S "$ROOT" -B "$dir" -G Ninja "$@"; fi
}

# The sanitizer builds: optimised enough to run the suite, debug info for the reports, assertions
# (Eigen's and libstdc++'s bounds checks) on.
SAN_FLAGS=(-DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g -D_GLIBCXX_ASSERTIONS"
  "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O1 -g" -DOVO_BUILD_BENCH=OFF)

# ASan + UBSan over the ctest suite. Suppressions only for reports inside Debian's (not
# instrumented) libraries: scripts/sanitizers/*.supp say which and why.
export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1:abort_on_error=0:strict_init_order=1:detect_stack_use_after_return=0:allocator_may_return_null=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:suppressions=$SUPP/ubsan.supp"
export LSAN_OPTIONS="suppressions=$SUPP/lsan.supp:print_suppressions=0"
export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$SUPP/tsan.supp"

# The fixed subset CI runs under ASan + UBSan when the whole suite does not fit its time: every
# reader of outside data (io, camera calibration files, configs, the fuzz regressions), the
# window estimator's core, and the runners end to end.
SUBSET='^(Dataset|TrajectoryIo|StagedFolder|Config|CalibIo|Ocam|Models|FuzzRegression|Targets/FuzzRegression|WindowCore|WindowProblem|WindowInit|WindowLidar|RunOutput|RunMetrics|Faults|Determinism|OnlinePipeline|OnlineRun)'
# ... and the programs that hold those tests (only these are built for the subset).
SUBSET_TARGETS=(ovo ovo_test_common ovo_test_camera ovo_test_io ovo_test_fuzz ovo_test_estimator
  ovo_test_apps ovo_test_sim ovo_test_calib)

# The threaded tests (tests/apps/online_*.cpp, the offline runner's two stages, faults under the
# pipeline), run under TSan.
TSAN_TESTS='^(OnlinePipeline|OnlineReplay|OnlineRun|LiveCamera|Estimators/OnlineTwoStage|OnlineTwoStage|Faults|Determinism)'

sanitize_asan() {
  local subset=$1 dir=$ROOT/build-asan start
  start=$(date +%s)
  configure "$dir" "${SAN_FLAGS[@]}" -DOVO_SANITIZE=address,undefined
  if [ "$subset" = 1 ]; then
    cmake --build "$dir" -j "$JOBS" --target "${SUBSET_TARGETS[@]}"
  else
    cmake --build "$dir" -j "$JOBS"
  fi
  echo "check.sh sanitize asan: build $(($(date +%s) - start)) s"
  start=$(date +%s)
  local filter=()
  if [ "$subset" = 1 ]; then filter=(-R "$SUBSET"); fi
  (cd "$dir" && ctest --output-on-failure -j "$JOBS" --timeout 1800 "${filter[@]}")
  echo "check.sh sanitize asan: ctest $(($(date +%s) - start)) s"
}

sanitize_tsan() {
  local dir=$ROOT/build-tsan start
  start=$(date +%s)
  configure "$dir" "${SAN_FLAGS[@]}" -DOVO_SANITIZE=thread
  cmake --build "$dir" -j "$JOBS" --target ovo ovo_live_camera ovo_test_apps ovo_tsan_serial_libraries
  echo "check.sh sanitize tsan: build $(($(date +%s) - start)) s"
  start=$(date +%s)
  # TBB and OpenCV loops serial (tests/sanitizers/tsan_serial_libraries.cpp): ovo's own threads
  # are what TSan checks.
  (cd "$dir" && LD_PRELOAD="$dir/tests/libovo_tsan_serial_libraries.so" \
    ctest --output-on-failure -j "$JOBS" --timeout 1800 -R "$TSAN_TESTS")
  echo "check.sh sanitize tsan: ctest $(($(date +%s) - start)) s"
}

cmd_sanitize() {
  local which=all subset=0
  for a in "$@"; do
    case "$a" in
      asan | tsan | all) which=$a ;;
      --subset) subset=1 ;;
      *) echo "check.sh sanitize: unknown argument '$a'" >&2; exit 2 ;;
    esac
  done
  case "$which" in
    asan) sanitize_asan "$subset" ;;
    tsan) sanitize_tsan ;;
    all) sanitize_asan "$subset" && sanitize_tsan ;;
  esac
}

# seed_corpus <target> <corpus dir>: the repository's seeds plus small pieces of ../shared/data
# (first lines of the long files; images as they are).
seed_corpus() {
  local t=$1 c=$2
  mkdir -p "$c"
  cp -n "$ROOT/tests/fuzz/seeds/$t/"* "$c/" 2>/dev/null || true
  [ -d "$SHARED" ] || return 0
  local head_lines=60
  case "$t" in
    ocam_calib)
      for f in "$SHARED"/romovi-fisheye-calib/calib_results.txt "$SHARED"/ocam-scaramuzza-sample/calib_results_*.txt; do
        [ -f "$f" ] && cp -n "$f" "$c/shared_$(basename "$f")"
      done ;;
    camera_yaml)
      find "$SHARED/euroc-v101-micro" "$SHARED/fisheye-calib-refs" -name '*.yaml' -size -16k 2>/dev/null |
        while read -r f; do cp -n "$f" "$c/shared_$(echo "$f" | md5sum | cut -c1-8).yaml"; done ;;
    trajectory_tum)
      for f in "$SHARED"/traj-eval-evo/freiburg1_xyz-groundtruth.txt "$SHARED"/traj-eval-evo/V102.txt; do
        [ -f "$f" ] && head -n $head_lines "$f" >"$c/shared_$(basename "$f")"
      done ;;
    trajectory_kitti)
      for f in "$SHARED"/traj-eval-evo/KITTI_00_gt.txt "$SHARED"/kitti07-first160/poses_07_time_prefixed.txt; do
        [ -f "$f" ] && head -n $head_lines "$f" >"$c/shared_$(basename "$f")"
      done ;;
    trajectory_euroc)
      f="$SHARED"/traj-eval-evo/V102_groundtruth.csv
      [ -f "$f" ] && head -n $head_lines "$f" >"$c/shared_V102_groundtruth.csv" ;;
    imu_csv)
      f="$SHARED"/euroc-v101-micro/mav0/imu0/data.csv
      [ -f "$f" ] && head -n $head_lines "$f" >"$c/shared_euroc_imu.csv" ;;
    image_list_csv)
      f="$SHARED"/euroc-v101-micro/mav0/cam0/data.csv
      [ -f "$f" ] && head -n 10 "$f" >"$c/shared_euroc_cam0.csv" ;;
    kitti_folder)
      local k="$SHARED"/kitti07-first160
      [ -d "$k" ] && { cat "$k/calib.txt"; echo ---; head -n 20 "$k/times.txt"; echo ---
        head -n 20 "$k/poses_07_time_prefixed.txt"; } >"$c/shared_kitti07.txt" ;;
    image)
      find "$SHARED/fisheye-calib-refs" -type f \( -name '*.png' -o -name '*.jpg' \) -size -64k 2>/dev/null |
        head -n 4 | while read -r f; do cp -n "$f" "$c/shared_$(basename "$f")"; done ;;
    bag_ros1 | bag_sqlite3 | bag_mcap)  # the real bags of rosbag-fixtures (bz2, lz4, zstd among them)
      local ext; case "$t" in bag_ros1) ext=bag ;; bag_sqlite3) ext=db3 ;; bag_mcap) ext=mcap ;; esac
      find "$SHARED/rosbag-fixtures" -type f -name "*.$ext" -size -400k 2>/dev/null |
        while read -r f; do cp -n "$f" "$c/shared_$(basename "$(dirname "$f")")_$(basename "$f")"; done ;;
  esac
}

# run_fuzz_target <target> <seconds>: one libFuzzer run; its log in build-fuzz/logs/<target>.log.
run_fuzz_target() {
  local t=$1 secs=$2 dir=$ROOT/build-fuzz
  local corpus=$dir/corpus/$t art=$dir/artifacts/$t log=$dir/logs/$t.log
  mkdir -p "$art" "$dir/logs"
  seed_corpus "$t" "$corpus"
  local start end status=0
  start=$(date +%s)
  # Images: OpenCV's own limit for formats ovo does not check first (1 Gpx by default).
  OPENCV_IO_MAX_IMAGE_PIXELS=16777216 ASAN_OPTIONS="$ASAN_OPTIONS" \
    nice -n 5 "$dir/fuzz/fuzz_$t" -max_total_time="$secs" -timeout=20 -rss_limit_mb=2048 \
    -max_len=65536 -print_final_stats=1 -artifact_prefix="$art/" "$corpus" >"$log" 2>&1 || status=$?
  end=$(date +%s)
  local runs cov ft
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || true)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -n 1 | grep -o '[0-9]*' || true)
  ft=$(grep -o 'ft: [0-9]*' "$log" | tail -n 1 | grep -o '[0-9]*' || true)
  local found
  found=$(find "$art" -type f | wc -l)
  printf '%-18s %8s s %12s execs %6s cov %7s ft %3s findings  exit %s\n' "$t" "$((end - start))" \
    "${runs:-?}" "${cov:-?}" "${ft:-?}" "$found" "$status"
}

cmd_fuzz() {
  local secs=${1:-60}
  shift || true
  local dir=$ROOT/build-fuzz
  CC=clang CXX=clang++ configure "$dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g" -DOVO_FUZZ=ON -DOVO_SANITIZE=address,undefined \
    -DOVO_BUILD_TESTS=OFF -DOVO_BUILD_BENCH=OFF
  local targets=("$@") build_targets=(ovo_fuzz_all)
  if [ ${#targets[@]} -gt 0 ]; then build_targets=("${targets[@]/#/fuzz_}"); fi
  cmake --build "$dir" -j "$JOBS" --target "${build_targets[@]}"
  if [ ${#targets[@]} -eq 0 ]; then
    mapfile -t targets < <(find "$dir/fuzz" -maxdepth 1 -name 'fuzz_*' -type f -printf '%f\n' | sed 's/^fuzz_//' | sort)
  fi
  printf '%-18s %10s %18s %10s %10s\n' target time executions coverage features
  export -f run_fuzz_target seed_corpus
  export ROOT SHARED ASAN_OPTIONS UBSAN_OPTIONS LSAN_OPTIONS
  printf '%s\n' "${targets[@]}" | xargs -P "${OVO_FUZZ_PARALLEL:-1}" -I{} bash -c "run_fuzz_target {} $secs"
  local total
  total=$(find "$dir/artifacts" -type f 2>/dev/null | wc -l)
  if [ "$total" -gt 0 ]; then
    echo "check.sh fuzz: $total input(s) in $dir/artifacts/ (crash, leak, timeout or OOM)" >&2
    return 1
  fi
}

cmd_soak() {
  local hours=${1:-1}
  shift || true
  local build=${OVO_BUILD_DIR:-$ROOT/build}
  configure "$build" -DCMAKE_BUILD_TYPE=Release
  cmake --build "$build" -j "$JOBS" --target ovo_soak
  mkdir -p "$build/soak"
  "$build/ovo_soak" --hours "$hours" --out "$build/soak" "$@"
}

# The packages of scripts/setup.sh for arm64 (the architecture-independent ones as they are), less
# ROS 1's, plus the cross toolchain and qemu-user.
ARM64_PACKAGES=(crossbuild-essential-arm64 qemu-user cmake ninja-build pkg-config
  libeigen3-dev libcli11-dev nlohmann-json3-dev opencl-headers
  libceres-dev:arm64 libsuitesparse-dev:arm64 libopencv-dev:arm64 ocl-icd-opencl-dev:arm64
  libgtest-dev:arm64 libgmock-dev:arm64 libopengv-dev:arm64 libspdlog-dev:arm64 libfmt-dev:arm64
  libyaml-cpp-dev:arm64 libtbb-dev:arm64 zlib1g-dev:arm64 libsqlite3-dev:arm64 libzstd-dev:arm64
  liblz4-dev:arm64 libbz2-dev:arm64)

cmd_arm64() {
  local root=${OVO_ARM64_ROOT:-$ROOT/build-arm64/root} sudo=""
  [ "$(id -u)" = 0 ] || sudo=sudo
  if [ ! -x "$root/usr/bin/aarch64-linux-gnu-g++" ]; then
    if ! command -v debootstrap >/dev/null; then
      $sudo apt-get update -qq && $sudo apt-get install -y -qq debootstrap >/dev/null
    fi
    [ -x "$root/bin/bash" ] ||
      $sudo debootstrap --variant=minbase bookworm "$root" http://deb.debian.org/debian
  fi
  # The source tree at /ovo (the build goes to its build-arm64/out), ../shared/data beside it;
  # unmounted on exit (ARM64_MOUNTED is global: the EXIT trap runs after this function returns).
  ARM64_SUDO=$sudo
  ARM64_MOUNTED=()
  unmount_all() {
    local i
    for ((i = ${#ARM64_MOUNTED[@]} - 1; i >= 0; i--)); do
      $ARM64_SUDO umount "${ARM64_MOUNTED[i]}" || true
    done
  }
  trap unmount_all EXIT
  bind() {
    $sudo mkdir -p "$2"
    mountpoint -q "$2" || { $sudo mount --bind "$1" "$2" && ARM64_MOUNTED+=("$2"); }
  }
  bind /proc "$root/proc"
  bind /dev "$root/dev"
  bind "$ROOT" "$root/ovo"
  if [ -d "$SHARED" ]; then bind "$SHARED" "$root/shared/data"; fi
  $sudo cp /etc/resolv.conf "$root/etc/resolv.conf"
  if [ ! -x "$root/usr/bin/aarch64-linux-gnu-g++" ]; then
    $sudo chroot "$root" bash -c "dpkg --add-architecture arm64 && apt-get update -qq &&
      DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends ${ARM64_PACKAGES[*]}"
  fi
  local start ctest_args=("$@") compare=0 tests=1
  if [ "${1:-}" = --compare ]; then
    compare=1 tests=0
  elif [ ${#ctest_args[@]} -eq 0 ]; then
    compare=1 ctest_args=(-LE apps)
  fi
  start=$(date +%s)
  $sudo chroot "$root" bash -c "cd /ovo && cmake -S . -B build-arm64/out -G Ninja \
      -DCMAKE_TOOLCHAIN_FILE=cmake/toolchains/aarch64-linux-gnu.cmake -DCMAKE_BUILD_TYPE=Release \
      -DOVO_WITH_ROS1=OFF -DOVO_BUILD_BENCH=OFF >/dev/null && cmake --build build-arm64/out -j $JOBS"
  echo "check.sh arm64: build $(($(date +%s) - start)) s"
  local status=0
  if ((tests)); then
    start=$(date +%s)
    # Two hours a test: qemu runs the longest (WindowConsistency's 30 seeds) 25-40x slower than
    # natively, about 45 minutes alone, and it passed one hour with other work beside it.
    $sudo chroot "$root" bash -c "cd /ovo/build-arm64/out && POCL_CACHE_DIR=/tmp/pocl \
        ctest --output-on-failure -j $JOBS --timeout 7200 $(printf '%q ' "${ctest_args[@]}")" ||
      status=$?
    echo "check.sh arm64: ctest $(($(date +%s) - start)) s"
  fi
  if ((compare)); then arm64_compare "$root" || status=1; fi
  return $status
}

# The largest RMS difference between the arm64 and the x86-64 trajectory of one estimator on the
# end-to-end subset's row, in metres: measured 3e-15 to 6e-13 (rounding), while one decision taken
# otherwise (another RANSAC seed) moves them by 1e-4 (docs/speed.md#arm64).
ARM64_TOLERANCE_M=0.000001

# arm64_compare <root>: the end-to-end subset of `check.sh arm64` (see the header).
arm64_compare() {
  local root=$1 work=build-arm64/compare e rms max status=0
  # The x86-64 build of the same source (built or brought up to date; errexit does not hold in a
  # function called before ||, so every step checks its own status).
  configure build -DCMAKE_BUILD_TYPE=Release || return 1
  cmake --build build --target ovo -j "$JOBS" || return 1
  rm -rf "$work"
  mkdir -p "$work"
  build/ovo simulate --duration 8 --out "$work/data" >"$work/simulate.log" 2>&1 ||
    { echo "check.sh arm64: ovo simulate failed ($work/simulate.log)"; return 1; }
  for e in vo kf window; do
    build/ovo run --quiet --dataset "$work/data" --estimator $e --out "$work/x86_64/$e" \
      >"$work/x86_64_$e.log" 2>&1 ||
      { echo "check.sh arm64: ovo run --estimator $e failed on x86-64 ($work/x86_64_$e.log)"; status=1; continue; }
    $sudo chroot "$root" bash -c "cd /ovo && qemu-aarch64 build-arm64/out/ovo run --quiet \
        --dataset $work/data --estimator $e --out $work/arm64/$e" >"$work/arm64_$e.log" 2>&1 ||
      { echo "check.sh arm64: ovo run --estimator $e failed under qemu ($work/arm64_$e.log)"; status=1; continue; }
    build/ovo eval --gt "$work/x86_64/$e/trajectory.txt" --est "$work/arm64/$e/trajectory.txt" \
      --format tum --align none >"$work/$e.json" ||
      { echo "check.sh arm64: ovo eval failed for $e"; status=1; continue; }
    rms=$(ate_value rmse <"$work/$e.json")
    max=$(ate_value max <"$work/$e.json")
    [ -n "$rms" ] || { echo "check.sh arm64: no RMS in $work/$e.json"; status=1; continue; }
    printf 'check.sh arm64: %-6s arm64 vs x86-64: RMS %.3g m, max %.3g m (ATE x86-64 %s, arm64 %s)\n' \
      $e "$rms" "$max" "$(ate_of "$work/x86_64/$e" "$work/data")" "$(ate_of "$work/arm64/$e" "$work/data")"
    awk -v r="$rms" -v t=$ARM64_TOLERANCE_M 'BEGIN { exit !(r <= t) }' ||
      { echo "check.sh arm64: $e differs by more than $ARM64_TOLERANCE_M m"; status=1; }
  done
  return $status
}

# ate_value <key> < eval.json: a value of `ovo eval`'s "ate" block (its first "<key>": line).
ate_value() {
  awk -F': ' -v key="\"$1\"" 'index($1, key) {sub(/,$/, "", $2); print $2; exit}'
}

# ate_of <run folder> <dataset>: the run's ATE against the dataset's ground truth, in metres.
ate_of() {
  printf '%.4f m' "$(build/ovo eval --gt "$2/groundtruth.txt" --est "$1/trajectory.txt" | ate_value rmse)"
}

cmd=${1:-help}
shift || true
case "$cmd" in
  sanitize) cmd_sanitize "$@" ;;
  fuzz) cmd_fuzz "$@" ;;
  soak) cmd_soak "$@" ;;
  arm64) cmd_arm64 "$@" ;;
  help | -h | --help) usage ;;
  *)
    echo "check.sh: unknown command '$cmd'" >&2
    usage >&2
    exit 2
    ;;
esac
