#!/usr/bin/env bash
# ovo_ros end to end on a real ROS 1 master (ctest label "ros"; exits 77, a skip, with a message
# where ROS 1 or the node is absent):
#   1. the node refuses a missing rig file, a bad one and no ~rig, with a message naming what is
#      wrong and a non-zero exit;
#   2. roslaunch ovo ovo.launch and rosbag record of what it publishes while a simulated
#      vineyard_row bag plays at half its rate: the published odometry's ATE within 1.2x of
#      `ovo run --realtime --rate 0.5`'s on the same bag (its poses as they went out,
#      trajectory_online.txt: the node publishes each frame's pose once); at the bag's own rate
#      (where this machine drops frames, see below) too: the TF odom -> base_link with every pose,
#      the rig's extrinsics as static transforms, the path, the diagnostics, no NaN, tracking at the
#      end (and at half rate no tracking loss);
#   3. the same bag at 3x, every topic silent for 6 s after its first 20 s and the IMU alone for 6 s
#      on a straight stretch later: the diagnostics say frames were dropped and which topics went
#      silent, the odometry goes on after each silence, no NaN, tracking at the end. (At 3x without
#      the silences this machine drops 7-144 of the 825 frames and lost no track in 20 runs,
#      tests/ros/rate_sweep.sh; with the keyframes solved by Ceres it dropped two in three and lost
#      the camera for a few frames in some runs. A loss is allowed here if it is recovered: a
#      silence of every topic may end one. docs/ros.md gives the figures.)
# The node's CPU and `ovo run --realtime`'s are printed (not checked: no timed assertions).
#
#   tests/ros/ros_node_test.sh BUILD_DIR [WORK_DIR]
set -euo pipefail
USAGE="ros_node_test.sh BUILD_DIR [WORK_DIR]"
source "$(dirname "$0")/session.sh"

# 1. Bad set-ups: a clear message naming the problem and a non-zero exit.
expect_refusal() {  # name, expected text, node arguments...
  local name=$1 text=$2; shift 2
  local rc=0
  timeout 60 "$NODE" "__name:=ovo_$name" "$@" >"$WORK/$name.log" 2>&1 || rc=$?
  [ "$rc" -ne 0 ] || fail "ovo_ros with $name exited 0"
  [ "$rc" -ne 124 ] || fail "ovo_ros with $name did not exit"
  grep -q -- "$text" "$WORK/$name.log" || { cat "$WORK/$name.log"; fail "ovo_ros with $name did not say '$text'"; }
  echo "refused ($name, exit $rc): $(grep -m1 -- "$text" "$WORK/$name.log")"
}
expect_refusal no_rig "~rig"
expect_refusal missing_rig "$WORK/missing/rig.yaml" "_rig:=$WORK/missing/rig.yaml"
printf 'camera: {T_B_C: [1, 2, 3]}\n' >"$WORK/bad_rig.yaml"
expect_refusal bad_rig "$WORK/bad_rig.yaml" "_rig:=$WORK/bad_rig.yaml"

# 2. Accuracy: the bag at half its rate through the node and through `ovo run --realtime --rate
# 0.5`. At its own rate this two-core machine is at capacity with ovo alone (latency median about
# 55 ms for 50 ms frames), the ROS transport, rosbag play and rosbag record take a tenth of a core
# more, and the node then drops frames that ovo run does not: one run of each differs by the
# machine's timing more than by the adapter (5.0-8.8 mm for the node, 5.0-7.4 for ovo run over a
# dozen runs, docs/ros.md). At half rate neither drops a frame and the comparison is the adapter's
# own (stamps, order, conversions). 3. The bag at its rate: what the robot sees.
sleep 2  # the node's start-up (its estimator, OpenCL kernels) done before the bag begins
echo "playing the bag at half its rate"
run_node half rosbag play --quiet --wait-for-subscribers --rate 0.5 "$DATA/run.bag"
"$OVO" eval --gt "$DATA/groundtruth.txt" --est "$WORK/half.tum" >"$WORK/half.eval.json"
echo "reference: ovo run --realtime --rate 0.5 on the same bag"
"$OVO" run --dataset "$DATA/run.bag" --realtime --rate 0.5 --estimator window \
  --out "$WORK/reference" --quiet >"$WORK/reference.log" 2>&1 ||
  { cat "$WORK/reference.log"; fail "ovo run --realtime"; }
"$OVO" eval --gt "$DATA/groundtruth.txt" --est "$WORK/reference/trajectory_online.txt" \
  >"$WORK/reference.eval.json"
echo "half rate: $(json "$WORK/half.json" "['odometry']") poses published," \
  "$(json "$WORK/half.json" "['frames_dropped']") frames dropped; ATE node" \
  "$(ate_of "$WORK/half.eval.json") m, ovo run --realtime $(ate_of "$WORK/reference.eval.json") m" \
  "(its final trajectory $(json "$WORK/reference/metrics.json" "['ate_rmse_m']") m," \
  "$(json "$WORK/reference/metrics.json" "['frames_dropped']") frames dropped); CPU node" \
  "$(cat "$WORK/half.cpu") s, ovo run --realtime" \
  "$(json "$WORK/reference/metrics.json" "['timing']['cpu_s']") s"
sleep 2
echo "playing the bag at its rate"
run_node rate1 rosbag play --quiet --wait-for-subscribers "$DATA/run.bag"
"$OVO" eval --gt "$DATA/groundtruth.txt" --est "$WORK/rate1.tum" >"$WORK/rate1.eval.json"
echo "rate 1: $(json "$WORK/rate1.json" "['odometry']") poses published," \
  "$(json "$WORK/rate1.json" "['frames_dropped']") frames dropped; ATE node" \
  "$(ate_of "$WORK/rate1.eval.json") m; CPU node $(cat "$WORK/rate1.cpu") s"
"$PY" - "$WORK" <<'EOF' || fail "half rate and rate 1 (above)"
import json, sys
w = sys.argv[1]
ate = lambda f: json.load(open(f))["ate"]["rmse"]
node, ref = ate(w + "/half.eval.json"), ate(w + "/reference.eval.json")
problems = []
for k, least in (("half", 780), ("rate1", 500)):
    s = json.load(open("%s/%s.json" % (w, k)))
    if s["odometry"] < least: problems.append("%s: only %d odometry messages" % (k, s["odometry"]))
    if s["non_finite"]: problems.append("%s: %d non-finite odometry messages" % (k, s["non_finite"]))
    if s["odometry_frames"] != ["odom->base_link"]: problems.append("%s: frames %s" % (k, s["odometry_frames"]))
    if s["tf_odom_base_link"] < s["odometry"]:
        problems.append("%s: %d TFs for %d poses" % (k, s["tf_odom_base_link"], s["odometry"]))
    if s["path_poses"] < 100: problems.append("%s: a path of %d poses" % (k, s["path_poses"]))
    if s["diagnostics"] < 20: problems.append("%s: %d diagnostics" % (k, s["diagnostics"]))
    if s["errors"]: problems.append("%s: diagnostic errors %s" % (k, s["errors"][:3]))
    # At half rate nothing is dropped and the track must hold; at the bag's rate this machine
    # drops frames when anything else runs (a loss then seen beside a simulation: recovered).
    if k == "half" and s["tracking_losses"]:
        problems.append("%s: %d tracking losses" % (k, s["tracking_losses"]))
    if not s["tracking"]: problems.append("%s: not tracking at the end" % k)
    print("%s: %d tracking losses" % (k, s["tracking_losses"]))
    # The rig's extrinsics as static transforms to the bag's frames (T_B_C, T_B_L row-major).
    rig = dict(l.split(":", 1) for l in open(w + "/row/rig.yaml") if l[:5] in ("T_B_C", "T_B_L"))
    for key, frame in (("T_B_C", "camera"), ("T_B_L", "laser")):
        m = [float(x) for x in rig[key].split("]")[0].strip(" [").split(",")]
        got = s["tf_static"].get("base_link->" + frame)
        if got is None or max(abs(got[i] - m[4 * i + 3]) for i in range(3)) > 1e-6:
            problems.append("%s: static transform base_link->%s %s, the rig's %s" %
                            (k, frame, got, [m[3], m[7], m[11]]))
print("half rate ATE: node %.4f m, ovo run --realtime %.4f m (x%.2f)" % (node, ref, node / ref))
if not node <= 1.2 * ref:
    problems.append("ATE %.4f m > 1.2 x ovo run --realtime's %.4f m" % (node, ref))
for p in problems: print("  " + p)
sys.exit(1 if problems else 0)
EOF

# 4. At 3x; every topic silent for 6 s after the first 20 s of the bag; the IMU alone silent for
# 6 s (the camera and the LiDAR at their rate) on the straight return row, 30-36 s.
echo "playing the bag at 3x with silences"
sleep 2
run_node rate3 bash -c "
  rosbag play --quiet --wait-for-subscribers --rate 3 --duration 20 '$DATA/run.bag' && sleep 6 &&
  rosbag play --quiet --rate 3 --start 20 --duration 10 '$DATA/run.bag' &&
  rosbag play --quiet --start 30 --duration 6 '$DATA/run.bag' --topics /camera/image_raw /scan &&
  rosbag play --quiet --rate 3 --start 36 '$DATA/run.bag'"
"$OVO" eval --gt "$DATA/groundtruth.txt" --est "$WORK/rate3.tum" >"$WORK/rate3.eval.json"
t0=$(awk '!/^#/ {print $1; exit}' "$DATA/groundtruth.txt")
echo "rate 3: $(json "$WORK/rate3.json" "['odometry']") poses published," \
  "$(json "$WORK/rate3.json" "['frames_dropped']") frames dropped; ATE node" \
  "$(ate_of "$WORK/rate3.eval.json") m"
"$PY" - "$WORK/rate3.json" "$WORK/rate3.tum" "$t0" <<'EOF' || fail "rate 3 (above)"
import json, sys
s = json.load(open(sys.argv[1])); t0 = float(sys.argv[3])
stamps = [float(l.split()[0]) - t0 for l in open(sys.argv[2])]
problems = []
if s["frames_dropped"] <= 0: problems.append("no frames dropped at 3x (the diagnostics' count)")
if not any("frames dropped" in w for w in s["warnings"]): problems.append("no warning of dropped frames")
def silent(topic):
    return any("no message on %s for %s" % (topic, n) in w for w in s["warnings"] for n in ("5.", "6."))
if not silent("/camera/image_raw"): problems.append("no warning that the camera went silent for 5 s")
if not silent("/imu/data"): problems.append("no warning that the IMU went silent for 5 s")
if not any(21 < t < 29 for t in stamps): problems.append("no odometry after the first silence")
if not any(31 < t < 35 for t in stamps): problems.append("no odometry while the IMU was silent")
if not any(t > 38 for t in stamps): problems.append("no odometry after the IMU came back")
if s["non_finite"]: problems.append("%d non-finite odometry messages" % s["non_finite"])
if not s["tracking"]: problems.append("not tracking at the end")
if s["errors"]: problems.append("diagnostic errors %s" % s["errors"][:3])
print("rate 3: %d tracking losses (recovered)" % s["tracking_losses"])
for p in problems: print("  " + p)
sys.exit(1 if problems else 0)
EOF
PASSED=1
echo "PASS"
