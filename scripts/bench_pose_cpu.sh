#!/usr/bin/env bash
# CPU per thread of collision_monitor_node while checks of seconds run (three bodies of 1,000
# overlapping boxes) and ~body_poses moves them at 20 Hz: the check thread should have a core to
# itself, no callback thread spinning beside it (docs/reliability.md, "pose callbacks no longer
# wait for a check"). Uses the node of an existing build, on a private ROS master.
#   scripts/bench_pose_cpu.sh [seconds] [bodies]   # default 20 s; `bodies`: a ~bodies ADD with
#                                                  # each pose message. CM_BUILD: the build (build/)
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
# shellcheck source=scripts/env.sh
source "$ROOT/scripts/env.sh"
cm_source_devel
PORT="$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1]); s.close()')"
export ROS_MASTER_URI="http://127.0.0.1:$PORT" ROS_HOSTNAME=127.0.0.1
unset ROS_IP || true
LOG="$(mktemp -d)"
roscore -p "$PORT" >"$LOG/roscore.log" 2>&1 &
core_pid=$!
trap 'kill -INT "${node_pid:-0}" 2>/dev/null || true; kill "$core_pid" 2>/dev/null || true; wait || true; rm -rf "$LOG"' EXIT
for _ in $(seq 50); do rostopic list >/dev/null 2>&1 && break; sleep 0.2; done
"$CM_BUILD/devel/lib/collision_monitor/collision_monitor_node" _publish_markers:=false \
  >"$LOG/node.log" 2>&1 &
node_pid=$!
sleep 2
/usr/bin/python3 "$ROOT/scripts/bench_pose_cpu.py" "$node_pid" "${1:-20}" ${2:+"$2"}
