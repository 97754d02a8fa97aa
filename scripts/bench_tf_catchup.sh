#!/usr/bin/env bash
# The cost of catch-up at TF's rate (docs/reliability.md, "Catch-up at TF's rate"): the PR2 of
# example-robot-data moving every joint on TF at 100 Hz (robot_state_publisher), a ball on
# ~body_poses at 10 Hz (stamps apart: the world keeps poses; `static`: posed once, stamped 0 in the
# fixed frame, a world posed at one time), the monitor at rate 20 without markers; prints the
# monitor's /diagnostics figures every 5 s. Uses the node of an existing build, on a private ROS
# master.
#   scripts/bench_tf_catchup.sh [check_on_tf] [seconds] [moving|static]
#   (default false 25 moving). CM_BUILD: the build
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
# shellcheck source=scripts/env.sh
source "$ROOT/scripts/env.sh"
cm_source_devel
DATA="${CM_ROBOT_DATA:-$ROOT/../shared/data}"
PORT="$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1]); s.close()')"
export ROS_MASTER_URI="http://127.0.0.1:$PORT" ROS_HOSTNAME=127.0.0.1
unset ROS_IP || true
LOG="$(mktemp -d)"
roscore -p "$PORT" >"$LOG/roscore.log" 2>&1 &
pids=($!)
trap 'kill -INT "${pids[@]}" 2>/dev/null || true; wait || true; rm -rf "$LOG"' EXIT
for _ in $(seq 50); do rostopic list >/dev/null 2>&1 && break; sleep 0.2; done
rosparam set robot_description -t "$DATA/example-robot-data/robots/pr2_description/urdf/pr2.urdf"
/usr/bin/python3 "$ROOT/scripts/bench_tf_catchup.py" joints _rate:=100 >"$LOG/joints.log" 2>&1 &
pids+=($!)
rosrun robot_state_publisher robot_state_publisher _publish_frequency:=100 >"$LOG/rsp.log" 2>&1 &
pids+=($!)
"$CM_BUILD/devel/lib/collision_monitor/collision_monitor_node" _publish_markers:=false _rate:=20 \
  _check_on_tf:="${1:-false}" _diagnostic_period:=5 >"$LOG/node.log" 2>&1 &
pids+=($!)
sleep 3
/usr/bin/python3 "$ROOT/scripts/bench_tf_catchup.py" ball "${2:-25}" "${3:-moving}"
