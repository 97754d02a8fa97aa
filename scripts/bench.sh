#!/usr/bin/env bash
# Builds the core benchmark (Release, -O3 -DNDEBUG, ROS-free core only) in build-bench/ and runs
# it: 5 repetitions, medians, JSON in build-bench/bench_core.json, then the ratio table and target
# check of bench/compare.py. Results are recorded by hand in docs/benchmarks.md.
#
#   scripts/bench.sh                      # everything (about 15 minutes on 2 cores)
#   scripts/bench.sh --benchmark_filter='hull'   # extra arguments go to the benchmark binary
#   CM_BENCH_CPU=1 scripts/bench.sh       # pin to CPU 1 (default: CPU 1 when taskset exists)
#   CM_BENCH_REPS=3 CM_BENCH_MIN_TIME=0.2 scripts/bench.sh
#   CM_BENCH_INTERLEAVE=0 scripts/bench.sh   # repetitions in order (default: random interleaving)
# The repetitions of all benchmarks run in random order (--benchmark_enable_random_interleaving):
# on a shared VM the machine's speed drifts by tens of percent within minutes, and in-order runs
# put one library's rows in one state and another's in the next; interleaved, every row's median
# is drawn from the same stretch of time, which is what a ratio needs.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
BUILD="${CM_BENCH_BUILD:-$ROOT/build-bench}"
REPS="${CM_BENCH_REPS:-5}"
MIN_TIME="${CM_BENCH_MIN_TIME:-0.3}"
CPU="${CM_BENCH_CPU:-1}"
INTERLEAVE=true
if [ "${CM_BENCH_INTERLEAVE:-1}" = 0 ]; then INTERLEAVE=false; fi

cmake -S "$ROOT" -B "$BUILD" -DCOLLISION_MONITOR_CORE_ONLY=ON -DCOLLISION_MONITOR_BENCHMARKS=ON \
  -DCOLLISION_MONITOR_WERROR=ON -DCMAKE_BUILD_TYPE=Release >"$BUILD.configure.log" 2>&1 \
  || { cat "$BUILD.configure.log"; exit 1; }
cmake --build "$BUILD" --target collision_monitor_bench_core -j"${CM_BENCH_JOBS:-2}"

PIN=()
if command -v taskset >/dev/null 2>&1 && [ "$CPU" != "none" ]; then PIN=(taskset -c "$CPU"); fi
echo "bench: load before: $(uptime)"
"${PIN[@]}" "$BUILD/collision_monitor_bench_core" \
  --benchmark_repetitions="$REPS" --benchmark_report_aggregates_only=true \
  --benchmark_min_time="$MIN_TIME" \
  --benchmark_enable_random_interleaving="$INTERLEAVE" \
  --benchmark_out="$BUILD/bench_core.json" --benchmark_out_format=json "$@" \
  || status=$?
echo "bench: load after: $(uptime)"
python3 "$ROOT/bench/compare.py" "$BUILD/bench_core.json"
exit "${status:-0}"
