#!/usr/bin/env bash
# End-to-end latency of collision_monitor_node over loopback: builds (if needed) the node and
# bench/latency_probe.cpp in build-bench-world/ (Release), then for each body count runs
# bench/latency.launch on a private ROS master (its own port, so other masters on this machine
# are not disturbed) and prints p50 / p90 / p99 / max of publish -> ~events.
#
#   scripts/bench_latency.sh                  # n = 10, 100, 1000; 1000 transitions each
#   CM_LAT_SIZES="1000" CM_LAT_TRANSITIONS=2000 scripts/bench_latency.sh
#   CM_LAT_NO_BUILD=1 scripts/bench_latency.sh
# Per-transition CSVs: $CM_BUILD/latency_n<N>.csv. Results are recorded by hand in
# docs/benchmarks.md ("World cycle and latency").
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
export CM_BUILD="${CM_BENCH_WORLD_BUILD:-$ROOT/build-bench-world}"
# shellcheck source=scripts/env.sh
source "$ROOT/scripts/env.sh"
SIZES="${CM_LAT_SIZES:-10 100 1000}"
TRANSITIONS="${CM_LAT_TRANSITIONS:-1000}"

if [ -z "${CM_LAT_NO_BUILD:-}" ]; then
  if [ ! -f "$CM_BUILD/CMakeCache.txt" ]; then
    cmake -S "$ROOT" -B "$CM_BUILD" -DPYTHON_EXECUTABLE=/usr/bin/python3 \
      -DCOLLISION_MONITOR_BENCHMARKS=ON -DCOLLISION_MONITOR_WERROR=ON \
      -DCMAKE_BUILD_TYPE=Release >"$CM_BUILD.configure.log" 2>&1 \
      || { cat "$CM_BUILD.configure.log"; exit 1; }
  fi
  cmake --build "$CM_BUILD" -j"${CM_BENCH_JOBS:-2}" \
    --target collision_monitor_node collision_monitor_latency_probe
fi
cm_source_devel

# A free port for a private master.
PORT="$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1]); s.close()')"
export ROS_MASTER_URI="http://127.0.0.1:$PORT"
export ROS_HOSTNAME=127.0.0.1
unset ROS_IP || true

status=0
summary=()
for n in $SIZES; do
  echo "bench_latency: n=$n, $TRANSITIONS transitions; load before: $(uptime)"
  out="$CM_BUILD/latency_n$n.csv"
  log="$CM_BUILD/latency_n$n.log"
  if roslaunch -p "$PORT" --screen "$ROOT/bench/latency.launch" n:="$n" \
      transitions:="$TRANSITIONS" output:="$out" >"$log" 2>&1; then :; else
    echo "bench_latency: roslaunch failed for n=$n (log: $log)"; status=1
  fi
  line="$(grep -a '^latency n=' "$log" | tail -1 || true)"
  if [ -z "$line" ]; then
    echo "bench_latency: no result for n=$n; last lines of $log:"; tail -20 "$log"; status=1
  else
    echo "$line"; summary+=("$line")
  fi
  echo "bench_latency: load after: $(uptime)"
done
echo
printf '%s\n' "${summary[@]}"
exit "$status"
