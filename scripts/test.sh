#!/usr/bin/env bash
# Every test: install dependencies, build with -Werror, run the whole CTest suite (core gtests,
# world gtests, rostests over a real roscore), clang-tidy over the sources (.clang-tidy) and the
# scripts' checks (scripts/lint.sh), then the geometry core again under ASan+UBSan, a bounded
# libFuzzer run on the core, then a build inside a catkin workspace, then the core alone installed
# and used by a plain CMake program, then the node and nodelet under ThreadSanitizer. Prints each
# step's time, then the totals. Exits non-zero on any failure.
set -euo pipefail
source "$(dirname "$0")/env.sh"
JOBS="$(nproc)"
PASSED=0
FAILED=0
# run_ctest <build dir> [env...]: runs the suite there (the tests CM_CTEST_SELECT selects, e.g.
# "-R name"; all by default), adds its counts to the totals.
run_ctest() {
  local dir="$1"
  shift
  local log="$dir/ctest.log"
  local rc=0
  local select=()
  read -r -a select <<<"${CM_CTEST_SELECT:-}"
  (cd "$dir" && env "$@" ctest --output-on-failure -j"$JOBS" --timeout 900 "${select[@]}") 2>&1 | tee "$log" || rc=1
  local line
  line="$(grep -E "tests passed, [0-9]+ tests? failed out of [0-9]+" "$log" | tail -1)"
  if [ -z "$line" ]; then
    echo "test.sh: no CTest summary in $dir" >&2
    FAILED=$((FAILED + 1))
    return
  fi
  local total failed
  failed="$(sed -E 's/.* ([0-9]+) tests? failed out of ([0-9]+).*/\1/' <<<"$line")"
  total="$(sed -E 's/.* ([0-9]+) tests? failed out of ([0-9]+).*/\2/' <<<"$line")"
  PASSED=$((PASSED + total - failed))
  FAILED=$((FAILED + failed))
  if [ "$total" -eq 0 ]; then FAILED=$((FAILED + 1)); echo "test.sh: no tests ran in $dir" >&2; fi
  [ "$rc" -eq 0 ] || [ "$failed" -gt 0 ] || FAILED=$((FAILED + 1))
}
# counted <command...>: runs it, and counts it as one test passed or failed.
counted() {
  if "$@"; then PASSED=$((PASSED + 1)); else FAILED=$((FAILED + 1)); fi
}
# step <title>: closes the step before (its time goes to TIMES) and opens the next.
TIMES=""
STEP=""
STEP_START=$SECONDS
step() {
  if [ -n "$STEP" ]; then TIMES="$TIMES${TIMES:+, }$STEP $((SECONDS - STEP_START)) s"; fi
  STEP="${1%% *}"
  STEP_START=$SECONDS
  [ -z "$1" ] || echo "=== $1"
}
step "0/7 apt dependencies (scripts/install_deps.sh)"
bash "$CM_ROOT/scripts/install_deps.sh"

step "1/7 standalone build (-Werror) and full test suite"
bash "$CM_ROOT/scripts/build.sh" -DCOLLISION_MONITOR_WERROR=ON
cm_source_devel
if [ ! -d "$CM_ROBOT_DATA/example-robot-data" ]; then
  echo "test.sh: robot data not found at $CM_ROBOT_DATA (set CM_ROBOT_DATA)" >&2
  exit 1
fi
run_ctest "$CM_BUILD" CM_ARTIFACTS="$CM_BUILD/test_results"

step "2/7 static analysis: clang-tidy over src/ and examples/ (the checks of .clang-tidy), shellcheck and pyflakes over the scripts (scripts/lint.sh); every finding an error"
counted bash "$CM_ROOT/scripts/tidy.sh" "$CM_BUILD"
counted bash "$CM_ROOT/scripts/lint.sh"

step "3/7 geometry core under AddressSanitizer + UndefinedBehaviorSanitizer"
SAN_BUILD="$CM_BUILD-asan"
cmake -S "$CM_ROOT" -B "$SAN_BUILD" -DCOLLISION_MONITOR_CORE_ONLY=ON -DCOLLISION_MONITOR_SANITIZE=ON \
  -DCOLLISION_MONITOR_WERROR=ON -DCOLLISION_MONITOR_BENCHMARKS=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build "$SAN_BUILD" -j"$JOBS"
run_ctest "$SAN_BUILD" ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  CM_SWEEP_SCALE="${CM_SWEEP_SCALE_SANITIZER:-0.1}"

step "4/7 libFuzzer (clang, ASan + UBSan) on the geometry core, the world model and the ROS layer's input: replay the corpora, fuzz ${CM_FUZZ_RUNS:-1200}, ${CM_FUZZ_WORLD_RUNS:-3000} and ${CM_FUZZ_ROS_RUNS:-20000} inputs (seed ${CM_FUZZ_SEED:-1}, at most ${CM_FUZZ_SECONDS:-120} s each)"
# Fixed seed and input count: the same inputs on every machine (open findings of longer runs are
# in fuzz/open/core, docs/reliability.md). The ROS target uses the messages built in step 1.
counted env CM_FUZZ_SEED="${CM_FUZZ_SEED:-1}" CM_FUZZ_RUNS="${CM_FUZZ_RUNS:-1200}" \
  CM_FUZZ_WORLD_RUNS="${CM_FUZZ_WORLD_RUNS:-3000}" CM_FUZZ_ROS_RUNS="${CM_FUZZ_ROS_RUNS:-20000}" \
  bash "$CM_ROOT/scripts/fuzz.sh" "${CM_FUZZ_SECONDS:-120}"

step "5/7 build and install inside a catkin workspace (catkin_make install), the demo from the install space, a downstream package and a plain CMake program against it"
# The workspace links back to this package (src/collision_monitor) and holds an install space with
# its launch files. roslaunch finds a package's files by walking its whole folder, following links
# and skipping only folders whose names start with a dot: a workspace named build-ws in the package
# made `roslaunch collision_monitor demo.launch` fail ("multiple files named", 82 candidates) in
# every tree that had run this script, scripts/demo.sh included. Hence the dot.
WS="$(dirname "$CM_BUILD")/.$(basename "$CM_BUILD")-ws"
mkdir -p "$WS/src"
ln -sfn "$CM_ROOT" "$WS/src/collision_monitor"
(cd "$WS" && catkin_make install -DPYTHON_EXECUTABLE="$CM_PYTHON" -DCOLLISION_MONITOR_BENCHMARKS=OFF \
  -DCATKIN_ENABLE_TESTING=OFF -DCOLLISION_MONITOR_WERROR=ON -j"$JOBS" >"$WS.log" 2>&1) \
  || { tail -50 "$WS.log"; exit 1; }
echo "catkin workspace build and install: ok"
bash "$CM_ROOT/scripts/check_install.sh" "$WS/install"
bash "$CM_ROOT/scripts/check_consumer.sh" "$WS/install"
bash "$CM_ROOT/scripts/check_core_consumer.sh" "$WS/install"
# The package's own launch files still resolve, once each, beside the workspace.
if ! out="$(roslaunch --files collision_monitor demo.launch 2>&1)"; then
  echo "test.sh: roslaunch cannot resolve collision_monitor demo.launch beside $WS: $out" | head -c 2000 >&2
  exit 1
fi
echo "roslaunch collision_monitor demo.launch resolves to $out: ok"

step "6/7 the geometry core alone: core-only build of the library (no tests), cmake --install, a plain CMake program against it"
CORE_BUILD="$CM_BUILD-core"
rm -rf "$CORE_BUILD/install"
cmake -S "$CM_ROOT" -B "$CORE_BUILD" -DCOLLISION_MONITOR_CORE_ONLY=ON -DBUILD_TESTING=OFF \
  -DCOLLISION_MONITOR_BENCHMARKS=OFF -DCOLLISION_MONITOR_WERROR=ON \
  -DCMAKE_INSTALL_PREFIX="$CORE_BUILD/install" >/dev/null
cmake --build "$CORE_BUILD" -j"$JOBS"
cmake --install "$CORE_BUILD" >/dev/null
# The install holds the core and nothing else: library, core headers, CMake package.
extra="$(find "$CORE_BUILD/install" -type f -printf '%P\n' | grep -Ev '^(include/collision_monitor/core/[a-z0-9_]+\.h|lib/libcollision_monitor_core\.(a|so)|lib/cmake/collision_monitor_core/collision_monitor_core[A-Za-z-]*\.cmake)$' || true)"
if [ -n "$extra" ] || [ ! -f "$CORE_BUILD/install/include/collision_monitor/core/query.h" ]; then
  echo "test.sh: the core-only install is not the core alone (or lacks its headers): ${extra:-no query.h}" >&2
  exit 1
fi
bash "$CM_ROOT/scripts/check_core_consumer.sh" "$CORE_BUILD/install"

step "7/7 the node and nodelet under ThreadSanitizer: every input thread driven at once, then SIGINT, unload, reload; no report (test/robustness/tsan.test)"
# Only the node, its libraries and the messages: the other tests have run in steps 1 and 3.
TSAN_BUILD="$CM_BUILD-tsan"
cmake -S "$CM_ROOT" -B "$TSAN_BUILD" -DPYTHON_EXECUTABLE="$CM_PYTHON" -DCOLLISION_MONITOR_TSAN=ON \
  -DCOLLISION_MONITOR_WERROR=ON -DCOLLISION_MONITOR_BENCHMARKS=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build "$TSAN_BUILD" -j"$JOBS" --target collision_monitor_node collision_monitor_generate_messages_py
CM_CTEST_SELECT="-R rostest_test_robustness_tsan" run_ctest "$TSAN_BUILD" \
  CM_ARTIFACTS="$CM_BUILD/test_results"

# Closing lines for CI: each step's time, then every CTest test of both builds.
step ""
echo "times: $TIMES; in all $SECONDS s"
echo "all: $PASSED passed, $FAILED failed"
[ "$FAILED" -eq 0 ]
