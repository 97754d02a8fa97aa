#!/usr/bin/env bash
# ~markers bandwidth with a real robot (docs/node.md, ~markers): a private roscore, the PR2's URDF
# (CM_ROBOT_DATA), robot_state_publisher, collision_monitor_node (defaults) and
# bench/marker_bandwidth.py, which sweeps the joints and counts the bytes of ~markers.
#
#   scripts/bench_markers.sh                       # PR2, moving, 10 s
#   CM_MARKERS_URDF=.../panda_collision.urdf scripts/bench_markers.sh 20 --still
#   scripts/bench_markers.sh 10 _marker_frame_locked:=false   # args starting with _ go to the node
# Uses the build in $CM_BUILD (default build/; build it first).
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
# shellcheck source=scripts/env.sh
source "$ROOT/scripts/env.sh"
cm_source_devel
SECONDS_MEASURED="${1:-10}"
shift || true
NODE_ARGS=() PY_ARGS=()
for a in "$@"; do
  if [[ $a == _* ]]; then NODE_ARGS+=("$a"); else PY_ARGS+=("$a"); fi
done
URDF="${CM_MARKERS_URDF:-$CM_ROBOT_DATA/example-robot-data/robots/pr2_description/urdf/pr2.urdf}"
PORT="${CM_MARKERS_PORT:-11411}"
export ROS_MASTER_URI="http://localhost:$PORT"
export ROS_HOME="${ROS_HOME:-$CM_BUILD/ros_home}" ROS_LOG_DIR="$CM_BUILD/ros_home/log"
mkdir -p "$ROS_LOG_DIR"
pids=()
cleanup() { for p in "${pids[@]}"; do kill -INT "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; }
trap cleanup EXIT
roscore -p "$PORT" >"$ROS_LOG_DIR/bench_markers_roscore.log" 2>&1 & pids+=($!)
for _ in $(seq 50); do rosparam list >/dev/null 2>&1 && break; sleep 0.2; done
rosparam set /robot_description -t "$URDF"
rosrun robot_state_publisher robot_state_publisher _publish_frequency:=50 \
  >"$ROS_LOG_DIR/bench_markers_rsp.log" 2>&1 & pids+=($!)
"$CM_BUILD/devel/lib/collision_monitor/collision_monitor_node" __name:=collision_monitor \
  "${NODE_ARGS[@]}" >"$ROS_LOG_DIR/bench_markers_node.log" 2>&1 & pids+=($!)
"$CM_PYTHON" "$ROOT/bench/marker_bandwidth.py" --seconds "$SECONDS_MEASURED" "${PY_ARGS[@]}"
