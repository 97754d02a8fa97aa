#!/usr/bin/env bash
# Instructions per query (valgrind's callgrind) of the core on the benchmark pools, with the
# driver bench/icount.cpp built in build-bench/ (Release, as scripts/bench.sh). Deterministic, so
# it compares small changes on a busy machine; times come from scripts/bench.sh only.
#   scripts/icount.sh                         # hull12: distance warm intersect
#   scripts/icount.sh hull100 intersect signed   # one pool, the queries given
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
BUILD="${CM_BENCH_BUILD:-$ROOT/build-bench}"
POOL="${1:-hull12}"
shift || true
QUERIES=("$@")
if [ ${#QUERIES[@]} -eq 0 ]; then QUERIES=(distance warm intersect); fi

cmake -S "$ROOT" -B "$BUILD" -DCOLLISION_MONITOR_CORE_ONLY=ON -DCOLLISION_MONITOR_BENCHMARKS=ON \
  -DCOLLISION_MONITOR_WERROR=ON -DCMAKE_BUILD_TYPE=Release >"$BUILD.configure.log" 2>&1 \
  || { cat "$BUILD.configure.log"; exit 1; }
cmake --build "$BUILD" --target collision_monitor_icount -j"${CM_BENCH_JOBS:-2}" >/dev/null

for q in "${QUERIES[@]}"; do
  n=8000
  [ "$q" = warm ] && n=16000
  out="$BUILD/callgrind.$POOL.$q"
  answers=$(valgrind --tool=callgrind --callgrind-out-file="$out" --toggle-collect='*run_queries*' \
    "$BUILD/collision_monitor_icount" "$POOL" "$q" 2>"$out.log")
  total=$(grep -E "Collected|refs:" "$out.log" | tail -n 1 | awk '{gsub(",","",$NF); print $NF}')
  echo "$POOL $q: $((total / n)) instructions per query ($total / $n); $answers"
done
