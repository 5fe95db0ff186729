#!/usr/bin/env bash
# A working session: the vineyard block (configs/sim/vineyard_block.yaml, ~630 m, 12 min) at
# one or more seeds, each estimator on the same dataset, and one table: final position error
# (% of the path), final heading error, ATE, scale, KITTI's segment errors (translation % and
# rotation deg / 100 m at 10, 50, 100 and 200 m), and the cost at the end of the run over its
# start (frame time, keyframe time, memory: timing.trend of metrics.json). For each seed,
# WORK/runs/s<seed>/drift.svg plots every estimator's position, heading and scale error against
# the distance driven. Datasets are simulated once into WORK/data (about an hour each at 4
# frames/s on two cores) and reused.
#
#   scripts/block.sh [--work DIR] [--jobs N] [--seeds "1 2 3"]
#                    [--estimators "vo kf window refine"] [--sim-set key=value ...]
#                    [--set key=value ...]
#
# --sim-set changes the block (e.g. world.row_length_m=90; a WORK's datasets are made once, so
# each --sim-set list needs a --work of its own); --set goes to every `ovo run` (a WORK's runs
# are reused too: other --set values need another --work). "refine" is the window with
# --refine full. Needs build/ovo (scripts/setup.sh build) and jq.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
OVO=${OVO_BIN:-$ROOT/build/ovo}
WORK=$ROOT/out/block
JOBS=2
SEEDS="1 2 3"
ESTIMATORS="vo kf window refine"
SETS=()
SIM_SETS=()

usage() { sed -n '2,/^set -euo/p' "$0" | grep '^#' | sed 's/^# \{0,1\}//' >&2; exit 2; }
while (($#)); do
  case "$1" in
    --work) WORK=$2; shift 2 ;;
    --jobs) JOBS=$2; shift 2 ;;
    --seeds) SEEDS=$2; shift 2 ;;
    --estimators) ESTIMATORS=$2; shift 2 ;;
    --set) SETS+=(--set "$2"); shift 2 ;;
    --sim-set) SIM_SETS+=(--set "$2"); shift 2 ;;
    -h | --help) usage ;;
    *) echo "block.sh: unknown argument '$1'" >&2; usage ;;
  esac
done
for s in $SEEDS; do
  [[ $s =~ ^[0-9]+$ ]] || { echo "block.sh: --seeds takes whole numbers, got '$s'" >&2; exit 2; }
done
# shellcheck source=scripts/run_checks.sh
source "$ROOT/scripts/run_checks.sh"
check_run_options "$JOBS" "$ESTIMATORS" "$OVO"
mkdir -p "$WORK/data" "$WORK/runs"

for seed in $SEEDS; do
  data=$WORK/data/s$seed
  if [ ! -f "$data/groundtruth.txt" ]; then
    echo "block.sh: simulating seed $seed into $data"
    "$OVO" simulate --config configs/sim/vineyard_block.yaml --seed "$seed" --out "$data" \
      --overwrite "${SIM_SETS[@]}" >"$WORK/data/s$seed.log" 2>&1
  fi
done

run_one() {  # seed estimator
  local seed=$1 e=$2 out=$WORK/runs/s$1/$2
  [ -f "$out/metrics.json" ] && return 0
  rm -rf "$out"
  local args=(--estimator window)
  case "$e" in vo | kf) args=(--estimator "$e") ;; refine) args+=(--refine full) ;; esac
  "$OVO" run --dataset "$WORK/data/s$seed" "${args[@]}" --out "$out" --quiet "${SETS[@]}" \
    >"$WORK/runs/s$seed.$e.log" 2>&1 || echo "block.sh: seed $seed $e failed (see $WORK/runs/s$seed.$e.log)"
}
export -f run_one
export WORK OVO
# The --set arguments one a line, read back as they were (spaces and wildcards kept).
SETS_FILE=$WORK/runs/sets.txt
printf '%s\n' "${SETS[@]+"${SETS[@]}"}" >"$SETS_FILE"
export SETS_FILE
jobs_list=()
for seed in $SEEDS; do for e in $ESTIMATORS; do jobs_list+=("$seed $e"); done; done
printf '%s\n' "${jobs_list[@]}" |
  xargs -P "$JOBS" -L 1 bash -c 'mapfile -t SETS <"$SETS_FILE"; [ -n "${SETS[0]:-}" ] || SETS=(); run_one "$0" "$1"'

printf '%-4s %-7s %7s %7s %7s %7s %7s | %-13s %-13s %-13s %-13s | %5s %5s %5s %5s\n' \
  seed est "pos%" "yaw" "ATEmm" "scale%" "lost" "10m %/deg" "50m" "100m" "200m" frame kf rss cpu
for seed in $SEEDS; do
  est_files=()
  for e in $ESTIMATORS; do
    m=$WORK/runs/s$seed/$e/metrics.json
    [ -f "$m" ] || { printf '%-4s %-7s (no result)\n' "$seed" "$e"; continue; }
    est_files+=(--est "$WORK/runs/s$seed/$e/trajectory.txt")
    jq -r --arg seed "$seed" --arg e "$e" '
      def f(x; n): if x == null then "-" else (x * pow(10; n) | round / pow(10; n) | tostring) end;
      def seg(L): (.segments // [] | map(select(.length_m == L)) | first) as $s
        | if $s == null then "-" else "\(f($s.trans_pct; 3))/\(f($s.rot_deg_per_100m; 2))" end;
      [$seed, $e, f(.final_pos_err_pct; 3), f(.final_yaw_err_deg; 2), f(if .ate_rmse_m == null then null else .ate_rmse_m * 1000 end; 1),
       f(.scale_err_pct; 2), (.tracking_losses | tostring), seg(10), seg(50), seg(100), seg(200),
       f(.timing.trend.ratio.frame_ms; 2), f(.timing.trend.ratio.keyframe_ms; 2),
       f(.timing.trend.ratio.rss; 2), f(.timing.trend.ratio.cpu_per_frame; 2)]
      | "\(.[0]) \(.[1]) \(.[2:] | join(" "))"' "$m" |
      awk '{printf "%-4s %-7s %7s %7s %7s %7s %7s | %-13s %-13s %-13s %-13s | %5s %5s %5s %5s\n", $1,$2,$3,$4,$5,$6,$7,$8,$9,$10,$11,$12,$13,$14,$15}'
  done
  if ((${#est_files[@]})); then
    "$OVO" eval --gt "$WORK/data/s$seed/groundtruth.txt" "${est_files[@]}" \
      --drift-plot "$WORK/runs/s$seed/drift.svg" >/dev/null ||
      echo "block.sh: no drift plot for seed $seed"
  fi
done
echo "pos% = final position error over the path (aligned on the first pose); yaw = final heading"
echo "error [deg]; segments: translation % / rotation deg per 100 m; frame, kf, rss, cpu = the"
echo "last tenth's median frame time, keyframe time, memory and CPU per frame over the first's."
