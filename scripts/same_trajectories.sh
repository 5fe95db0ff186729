#!/usr/bin/env bash
# Are two builds' answers the same? Runs scripts/accuracy.sh's 21 runs (vo, kf, window and
# --refine full) and vo, kf and window on KITTI 07 (../shared/data/kitti07-first160, when there)
# with each of two ovo binaries on the same datasets, then compares every trajectory.txt,
# keyframes.txt and gyro_bias.csv byte for byte. For a change that must not change behaviour
# (a refactor): build the old commit and the new one, then
#
#   scripts/same_trajectories.sh OLD_OVO NEW_OVO [--work DIR] [--jobs N]
#
# Exit 0 when every file is identical; the differing files are listed otherwise.
set -euo pipefail
cd "$(dirname "$0")/.."
(($# >= 2)) || { sed -n '2,/^set -euo/p' "$0" | grep '^#' | sed 's/^# \{0,1\}//' >&2; exit 2; }
A=$(realpath "$1") B=$(realpath "$2"); shift 2
WORK=out/same_trajectories JOBS=2
while (($#)); do
  case "$1" in
    --work) WORK=$2; shift 2 ;;
    --jobs) JOBS=$2; shift 2 ;;
    *) echo "same_trajectories.sh: unknown argument '$1'" >&2; exit 2 ;;
  esac
done
for bin in "$A" "$B"; do [ -x "$bin" ] || { echo "same_trajectories.sh: no program $bin" >&2; exit 2; }; done
mkdir -p "$WORK/data"
KITTI=../shared/data/kitti07-first160
for side in a b; do
  bin=$A; [ $side = b ] && bin=$B
  mkdir -p "$WORK/$side"
  ln -sfn "$(realpath "$WORK/data")" "$WORK/$side/data"  # one set of datasets for both
  echo "same_trajectories.sh: the 21 runs with $bin" >&2
  OVO_BIN=$bin bash scripts/accuracy.sh --work "$WORK/$side" --jobs "$JOBS" \
    --estimators "vo kf window refine" >"$WORK/$side.log" 2>&1
  if [ -d "$KITTI" ]; then
    for e in vo kf window; do
      rm -rf "$WORK/$side/kitti/$e"
      "$bin" run --quiet --dataset "$KITTI" --estimator "$e" --out "$WORK/$side/kitti/$e" >>"$WORK/$side.log" 2>&1
    done
  fi
done
n=0 differ=0
while IFS= read -r f; do
  n=$((n + 1))
  cmp -s "$WORK/a/$f" "$WORK/b/$f" || { echo "differs: $f"; differ=$((differ + 1)); }
done < <(cd "$WORK/a" && find -L runs kitti -name trajectory.txt -o -name keyframes.txt -o -name gyro_bias.csv 2>/dev/null | sort)
echo "$n files compared, $differ differ"
((n > 0 && differ == 0))
