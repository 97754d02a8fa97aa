#!/usr/bin/env bash
# Soak test, long version (issue #5; the short one runs in CI as test/robustness/soak.test):
# roscore (rostest's own, on a free port) + collision_monitor_node + soak_driver (1,000 bodies
# posed at 200 Hz, TF at 1 kHz, the three services called in parallel, a collide/separate
# schedule) + test_soak.py (RSS, /diagnostics, assertions). Prints the figures table.
#
#   scripts/soak.sh                 # 300 s measured after 15 s of warm-up
#   scripts/soak.sh 3600            # an hour
#   CM_SOAK_WARMUP=30 CM_SOAK_RSS_BOUND_MB=50 CM_SOAK_BODIES=1000 scripts/soak.sh 600
#
# Uses the build in $CM_BUILD (default build/): builds nothing when the node and the driver are
# there, else configures (if needed) and builds just those. Figures: $CM_ARTIFACTS/soak.txt and
# soak.json (default $CM_BUILD/soak/). Exit status: that of the rostest.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
# shellcheck source=scripts/env.sh
source "$ROOT/scripts/env.sh"
SECONDS_MEASURED="${1:-300}"
WARMUP="${CM_SOAK_WARMUP:-15}"
export CM_ARTIFACTS="${CM_ARTIFACTS:-$CM_BUILD/soak}"

bin="$CM_BUILD/devel/lib/collision_monitor"
if [ ! -x "$bin/collision_monitor_node" ] || [ ! -x "$bin/collision_monitor_soak_driver" ] ||
   [ ! -d "$CM_BUILD/devel/lib/python3/dist-packages/collision_monitor/msg" ]; then
  if [ ! -f "$CM_BUILD/CMakeCache.txt" ]; then
    cmake -S "$ROOT" -B "$CM_BUILD" -DPYTHON_EXECUTABLE="$CM_PYTHON" \
      -DCMAKE_BUILD_TYPE=Release >"$CM_BUILD.configure.log" 2>&1 \
      || { cat "$CM_BUILD.configure.log"; exit 1; }
  fi
  cmake --build "$CM_BUILD" -j"${CM_SOAK_JOBS:-2}" --target collision_monitor_node \
    collision_monitor_ros collision_monitor_soak_driver collision_monitor_generate_messages_py
fi
cm_source_devel
mkdir -p "$CM_ARTIFACTS"
rm -f "$CM_ARTIFACTS/soak.txt" "$CM_ARTIFACTS/soak.json"

echo "soak: ${SECONDS_MEASURED} s measured after ${WARMUP} s warm-up; build $CM_BUILD"
echo "soak: load before: $(uptime)"
status=0
rostest collision_monitor soak.test duration:="$SECONDS_MEASURED" warmup:="$WARMUP" \
  bodies:="${CM_SOAK_BODIES:-1000}" rss_bound_mb:="${CM_SOAK_RSS_BOUND_MB:-50}" || status=$?
echo "soak: load after: $(uptime)"
echo
if [ -f "$CM_ARTIFACTS/soak.txt" ]; then
  cat "$CM_ARTIFACTS/soak.txt"
else
  echo "soak: no figures (the run failed before the end; logs in $ROS_HOME/log)"
fi
echo
echo "soak: $([ "$status" -eq 0 ] && echo PASSED || echo FAILED); figures in $CM_ARTIFACTS"
exit "$status"
