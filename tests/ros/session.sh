# What the ROS 1 scripts share (sourced by ros_node_test.sh and rate_sweep.sh): the checks that
# skip where ROS 1 or the node is absent, the work folder, a master on a free port, the simulated
# vineyard_row bag (made once per work folder), and run_node, one node run with what it published.
# The sourcing script sets USAGE and passes its arguments: BUILD_DIR [WORK_DIR] first.
SRC=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
BUILD=$(cd "${1:?usage: $USAGE}" && pwd)
NODE=$BUILD/ros/ovo_ros
OVO=${OVO_BIN:-$BUILD/ovo}
PY=/usr/bin/python3  # Debian's, which has the rosbag module

skip() { echo "SKIP: $*"; exit 77; }
[ -x "$NODE" ] || skip "ovo_ros is not built (ROS 1's development packages were absent at configure time; scripts/setup.sh test installs them)"
for tool in roscore roslaunch rosbag rostopic; do
  command -v "$tool" >/dev/null || skip "$tool not found (Debian's python3-roslaunch, python3-rosbag, python3-rostopic)"
done
"$PY" -c "import rosbag" 2>/dev/null || skip "$PY cannot import rosbag (Debian's python3-rosbag)"

OWN_WORK=0
if [ -z "${2:-}" ]; then OWN_WORK=1; fi
WORK=${2:-$(mktemp -d /tmp/ovo_ros_test.XXXXXX)}
mkdir -p "$WORK"
PIDS=()
PASSED=0
cleanup() {
  for pid in "${PIDS[@]}"; do kill -INT -- "-$pid" 2>/dev/null || true; done
  sleep 1
  for pid in "${PIDS[@]}"; do kill -KILL -- "-$pid" 2>/dev/null || true; done
  # A passed run's own folder goes (the bag is 250 MB); a failed one stays to be looked at.
  if [ "$OWN_WORK" = 1 ] && [ "$PASSED" = 1 ]; then rm -rf "$WORK"; fi
}
trap cleanup EXIT
fail() { echo "FAIL: $*"; exit 1; }
# start NAME command...: in its own process group (so that it and its children can be stopped),
# output in WORK/NAME.log; the group's id in LAST_PID.
start() {
  local name=$1; shift
  setsid "$@" >"$WORK/$name.log" 2>&1 &
  LAST_PID=$!
  PIDS+=("$LAST_PID")
}
# stop PID: SIGINT (a node ends its run), then wait for it (at most 60 s).
stop() {
  kill -INT -- "-$1" 2>/dev/null || true
  for _ in $(seq 600); do kill -0 "$1" 2>/dev/null || return 0; sleep 0.1; done
  kill -KILL -- "-$1" 2>/dev/null || true
}
# cpu_s PID: user + system CPU of the process so far, s.
cpu_s() { awk -v hz="$(getconf CLK_TCK)" '{print ($14 + $15) / hz}' "/proc/$1/stat"; }
json() { "$PY" -c "import json,sys; print(json.load(open(sys.argv[1]))$2)" "$1"; }
# ate_of EVAL_JSON: the ATE RMS (m) of an `ovo eval` output.
ate_of() { json "$1" "['ate']['rmse']"; }

export POCL_CACHE_DIR=${POCL_CACHE_DIR:-$HOME/.cache/ovo-pocl}
export ROS_HOME=$WORK/ros_home ROS_LOG_DIR=$WORK/ros_home/log ROS_HOSTNAME=127.0.0.1
export ROS_PACKAGE_PATH=$BUILD/ros
PORT=$("$PY" -c "import socket; s = socket.socket(); s.bind(('127.0.0.1', 0)); print(s.getsockname()[1])")
export ROS_MASTER_URI=http://127.0.0.1:$PORT
mkdir -p "$ROS_LOG_DIR"

DATA=$WORK/row
if [ ! -f "$DATA/run.bag" ]; then
  echo "simulating vineyard_row into a ROS 1 bag"
  "$OVO" simulate --config "$SRC/configs/sim/vineyard_row.yaml" --format rosbag --out "$DATA" \
    --overwrite >"$WORK/simulate.log" 2>&1 || { cat "$WORK/simulate.log"; fail "ovo simulate"; }
fi

echo "starting a master on port $PORT"
start roscore roscore -p "$PORT"
for _ in $(seq 300); do rostopic list >/dev/null 2>&1 && break; sleep 0.1; done
rostopic list >/dev/null 2>&1 || { cat "$WORK/roscore.log"; fail "the master did not start"; }

# A node run: roslaunch, a recorder of what it publishes, the bag played by the given commands.
# Leaves WORK/NAME.bag, NAME.tum (the odometry), NAME.json (read_outputs.py) and NAME.cpu.
# advertised TOPIC: the master knows it (grep reads all of rostopic's output: with -q it would stop
# at the match, and rostopic's broken pipe would fail the pipeline under pipefail).
advertised() { rostopic list 2>/dev/null | grep -x -- "$1" >/dev/null; }
run_node() {
  local name=$1; shift
  start "$name.launch" roslaunch ovo ovo.launch "rig:=$DATA/rig.yaml"
  local launch=$LAST_PID
  for _ in $(seq 600); do advertised /ovo/odometry && break; sleep 0.1; done
  advertised /ovo/odometry ||
    { cat "$WORK/$name.launch.log"; fail "$name: the node did not advertise /ovo/odometry"; }
  start "$name.record" rosbag record -O "$WORK/$name.bag" /ovo/odometry /ovo/path /tf /tf_static \
    /diagnostics \
    __name:=ovo_test_recorder
  local record=$LAST_PID
  for _ in $(seq 300); do
    [ "$(rostopic info /ovo/odometry 2>/dev/null | grep -c ovo_test_recorder)" -gt 0 ] && break
    sleep 0.1
  done
  "$@"
  sleep 3  # the last frames out of the pipeline
  local node_pid
  node_pid=$(pgrep -f "^$NODE" | head -1 || true)
  [ -n "$node_pid" ] || { cat "$WORK/$name.launch.log"; fail "$name: the node is not running after the bag"; }
  cpu_s "$node_pid" >"$WORK/$name.cpu"
  stop "$record"
  stop "$launch"
  "$PY" "$SRC/tests/ros/read_outputs.py" "$WORK/$name.bag" "$WORK/$name.tum" "$WORK/$name.json"
}

