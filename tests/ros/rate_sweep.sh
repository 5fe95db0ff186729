#!/usr/bin/env bash
# ovo_ros against `ovo run --realtime` at a replay rate, run after run: how often each drops
# frames and loses the track on this machine (a measurement for docs/ros.md, not a test: a live
# run's drops depend on the machine's load, so one run says little). For each of RUNS runs:
# roslaunch ovo ovo.launch with `rosbag play --rate RATE` of the simulated vineyard_row bag, then
# `ovo run --realtime --rate RATE` on the same bag; one line each (frames dropped, tracking losses,
# tracking at the end, ATE of the poses as published, CPU), then the totals. Exit 1 when a run
# ends without tracking or publishes a non-finite pose; 77 where ROS 1 or the node is absent.
#
#   tests/ros/rate_sweep.sh BUILD_DIR [WORK_DIR [RATE [RUNS]]]     (RATE 3, RUNS 8 by default)
set -euo pipefail
USAGE="rate_sweep.sh BUILD_DIR [WORK_DIR [RATE [RUNS]]]"
RATE=${3:-3}
RUNS=${4:-8}
bad_argument() { echo "FAIL: $* (usage: $USAGE)"; exit 1; }
[[ "$RATE" =~ ^[0-9]*\.?[0-9]+$ ]] && awk -v r="$RATE" 'BEGIN { exit !(r > 0) }' ||
  bad_argument "RATE '$RATE': expected a replay rate > 0"
[[ "$RUNS" =~ ^[1-9][0-9]*$ ]] || bad_argument "RUNS '$RUNS': expected a whole number >= 1"
source "$(dirname "$0")/session.sh"

play() { rosbag play --quiet --wait-for-subscribers --rate "$RATE" "$DATA/run.bag" >"$WORK/play$1.log" 2>&1; }
mm() { awk -v m="$1" 'BEGIN { printf "%.1f", 1000 * m }'; }
sleep 2  # the master up before the first node
printf '%-8s %-20s %8s %7s %8s %9s %7s\n' run who dropped losses tracking "ATE mm" "CPU s"
declare -A losses_of=() lost_runs_of=()
# row RUN WHO DROPPED LOSSES TRACKING EVAL_JSON CPU: one line of the table, the losses tallied.
row() {
  printf '%-8s %-20s %8s %7s %8s %9s %7s\n' "$1" "$2" "$3" "$4" "$5" "$(mm "$(ate_of "$6")")" "$7"
  losses_of[$2]=$((${losses_of[$2]:-0} + $4))
  lost_runs_of[$2]=$((${lost_runs_of[$2]:-0} + ($4 > 0)))
}
bad=0
for i in $(seq "$RUNS"); do
  run_node "sweep$i" play "$i"
  "$OVO" eval --gt "$DATA/groundtruth.txt" --est "$WORK/sweep$i.tum" >"$WORK/sweep$i.eval.json"
  read -r dropped losses tracking non_finite < <("$PY" -c "
import json, sys
s = json.load(open(sys.argv[1]))
print(s['frames_dropped'], s['tracking_losses'], int(s['tracking']), s['non_finite'])" "$WORK/sweep$i.json")
  row "$i" ovo_ros "$dropped" "$losses" "$tracking" "$WORK/sweep$i.eval.json" "$(cat "$WORK/sweep$i.cpu")"
  if [ "$tracking" != 1 ] || [ "$non_finite" != 0 ]; then bad=1; fi

  "$OVO" run --dataset "$DATA/run.bag" --realtime --rate "$RATE" --estimator window \
    --out "$WORK/ref$i" --quiet >"$WORK/ref$i.log" 2>&1 || { cat "$WORK/ref$i.log"; fail "ovo run --realtime"; }
  "$OVO" eval --gt "$DATA/groundtruth.txt" --est "$WORK/ref$i/trajectory_online.txt" \
    >"$WORK/ref$i.eval.json"
  read -r dropped losses cpu < <("$PY" -c "
import json, sys
m = json.load(open(sys.argv[1]))
print(m['frames_dropped'], m['tracking_losses'], '%.1f' % m['timing']['cpu_s'])" "$WORK/ref$i/metrics.json")
  row "$i" "ovo run --realtime" "$dropped" "$losses" - "$WORK/ref$i.eval.json" "$cpu"
  sleep 2
done
echo "rate $RATE, $RUNS runs: ovo_ros lost the track in ${lost_runs_of[ovo_ros]} (${losses_of[ovo_ros]} losses)," \
  "ovo run --realtime in ${lost_runs_of[ovo run --realtime]} (${losses_of[ovo run --realtime]} losses)"
if [ "$bad" = 0 ]; then PASSED=1; fi  # a failed sweep's own folder stays to be looked at
exit $bad
