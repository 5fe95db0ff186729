# Sourced by scripts/accuracy.sh and scripts/block.sh: the checks of their common options and
# what they need before a run (messages name the script that sourced this file).
#   check_run_options JOBS "ESTIMATORS" OVO
# exits 2 on a --jobs that is not a whole number >= 1, an estimator other than vo, kf, window and
# refine, or no built ovo; installs jq when missing; sets POCL_CACHE_DIR.
check_run_options() {
  local name jobs=$1 estimators=$2 ovo=$3 e
  name=$(basename "$0")
  [[ $jobs =~ ^[1-9][0-9]*$ ]] || { echo "$name: --jobs takes a whole number >= 1, got '$jobs'" >&2; exit 2; }
  for e in $estimators; do
    case "$e" in vo | kf | window | refine) ;; *)
      echo "$name: --estimators takes vo, kf, window and refine, got '$e'" >&2; exit 2 ;;
    esac
  done
  [ -x "$ovo" ] || { echo "$name: no $ovo: build first (scripts/setup.sh build)" >&2; exit 2; }
  if ! command -v jq >/dev/null; then
    echo "$name: installing jq"
    local sudo=""; [ "$(id -u)" -ne 0 ] && sudo="sudo"
    $sudo apt-get install -y -qq jq >/dev/null || { $sudo apt-get update -qq && $sudo apt-get install -y -qq jq >/dev/null; }
  fi
  export POCL_CACHE_DIR=${POCL_CACHE_DIR:-${XDG_CACHE_HOME:-$HOME/.cache}/ovo-pocl}
}
