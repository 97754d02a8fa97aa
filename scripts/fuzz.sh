#!/usr/bin/env bash
# libFuzzer (clang, ASan + UBSan) on the geometry core, the world model and the ROS layer's input,
# in its own build folder.
#   bash scripts/fuzz.sh [seconds]      # default 60 per target; longer by hand, e.g. 3600
#                                       # (scripts/test.sh, the CI run: a fixed seed and input count)
# Targets: fuzz_core (fuzz/fuzz_core.cpp: two shapes, two poses, every query, against an oracle),
# fuzz_world (fuzz/fuzz_world.cpp: sequences of poses, checks, body changes and queries on bodies
# of spheres, capsules, boxes, convex hulls, cylinders, cones or ellipsoids that move, and turn in
# some cases, every check held to the contract and, with align_poses off or bodies posed in
# frames, to a reference model) and
# fuzz_ros_input (fuzz/fuzz_ros_input.cpp: ~bodies, ~body_poses and ~check_collision on the wire,
# URDF, SRDF and the ~bodies parameter through the node's own functions). fuzz_ros_input needs the
# message headers of a main build ($CM_BUILD/devel/include); without them only fuzz_core and
# fuzz_world run.
# CM_FUZZ_TARGETS (default "core world ros") picks some.
# CM_FUZZ_SEED: libFuzzer's -seed (default 0: a new random seed each run). CI (scripts/test.sh)
# fixes it, so that a CI failure is one a later run reproduces rather than a new random finding;
# exploration is the job of the longer runs by hand.
# CM_FUZZ_RUNS / CM_FUZZ_WORLD_RUNS / CM_FUZZ_ROS_RUNS: stop after this many inputs (libFuzzer
# -runs; default: none, time only). With a fixed seed and an empty corpus (a clean clone) the run
# is then the same on every machine.
# Steps, per target: build it with clang in $CM_FUZZ_BUILD (default build-fuzz), replay every
# committed failing input (fuzz/regressions/<core|world|ros>) and the seed corpus
# (fuzz/corpus/...), then fuzz for <seconds> from the seeds (new inputs go to
# $CM_FUZZ_BUILD/corpus-<core|world|ros>, never into the repository). A failing input is saved as
# $CM_FUZZ_BUILD/artifacts/crash-*: copy it into fuzz/regressions/<core|world|ros>/ (the replay
# gtests test_fuzz_regressions, test_world_fuzz_regressions and test_ros_fuzz_regressions then pin
# it in the normal suite). Exit code non-zero on any failure.
set -euo pipefail
source "$(dirname "$0")/env.sh"
SECONDS_TO_RUN="${1:-60}"
B="${CM_FUZZ_BUILD:-$CM_ROOT/build-fuzz}"
JOBS="${CM_FUZZ_JOBS:-1}"
TARGETS="${CM_FUZZ_TARGETS:-core world ros}"
MSG_INCLUDE="$CM_BUILD/devel/include"
if [[ " $TARGETS " == *" ros "* ]] && [ ! -f "$MSG_INCLUDE/collision_monitor/Body.h" ]; then
  echo "fuzz.sh: no generated messages in $MSG_INCLUDE (build the package first): fuzz_ros_input skipped"
  TARGETS="${TARGETS//ros/}"
  MSG_INCLUDE=""
fi
if [[ " $TARGETS " != *" ros "* ]]; then MSG_INCLUDE=""; fi
CXX=clang++ CC=clang cmake -S "$CM_ROOT/fuzz" -B "$B" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCM_MSG_INCLUDE="$MSG_INCLUDE" >"$B.configure.log" 2>&1 || { cat "$B.configure.log"; exit 1; }
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:${ASAN_OPTIONS:-}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:${UBSAN_OPTIONS:-}"
mkdir -p "$B/artifacts"

# fuzz_one <name> <runs> <libFuzzer options...>: build, replay, fuzz one target.
fuzz_one() {
  local name="$1" runs="$2"
  shift 2
  local exe="$B/fuzz_$name"
  [ "$name" = ros ] && exe="$B/fuzz_ros_input"
  cmake --build "$B" -j"$(nproc)" --target "$(basename "$exe")"
  mkdir -p "$B/corpus-$name"
  echo "fuzz.sh: $name: replaying fuzz/regressions/$name and the seed corpus"
  local inputs
  mapfile -t inputs < <(find "$CM_ROOT/fuzz/regressions/$name" "$CM_ROOT/fuzz/corpus/$name" -type f ! -name '*.md' | sort)
  "$exe" -runs=0 "${inputs[@]}" >"$B/replay-$name.log" 2>&1 || { tail -40 "$B/replay-$name.log"; return 1; }
  echo "fuzz.sh: $name: ${#inputs[@]} inputs replayed; fuzzing for ${SECONDS_TO_RUN} s"
  local rc=0 parallel=()
  if [ "$JOBS" -gt 1 ]; then parallel=(-fork="$JOBS"); fi
  (cd "$B" && "$exe" "$B/corpus-$name" "$CM_ROOT/fuzz/corpus/$name" "${parallel[@]}" \
    -seed="${CM_FUZZ_SEED:-0}" -runs="$runs" -max_total_time="$SECONDS_TO_RUN" -timeout=10 \
    -rss_limit_mb=2048 "$@" -artifact_prefix="$B/artifacts/" -print_final_stats=1 \
    >"$B/fuzz-$name.log" 2>&1) || rc=$?
  grep -E "^stat::(number_of_executed_units|average_exec_per_sec|peak_rss_mb)|^#[0-9]+.*DONE" "$B/fuzz-$name.log" || true
  if [ "$rc" -ne 0 ]; then
    grep -A30 -E "check failed|ERROR: (AddressSanitizer|libFuzzer)|runtime error|SUMMARY|malloc\(" "$B/fuzz-$name.log" | head -60
    echo "fuzz.sh: $name FAILED; inputs: $(ls "$B/artifacts")" >&2
    return "$rc"
  fi
  echo "fuzz.sh: $name ok ($(find "$B/corpus-$name" -mindepth 1 -maxdepth 1 | wc -l) corpus entries in $B/corpus-$name)"
}

failed=0
for t in $TARGETS; do
  case "$t" in
    core) fuzz_one core "${CM_FUZZ_RUNS:--1}" -max_len=2048 || failed=1 ;;
    # The set-up and up to 200 operations (a frame of six bodies turning reads up to 34 bytes, most
    # read 2 to 7).
    world) fuzz_one world "${CM_FUZZ_WORLD_RUNS:--1}" -max_len=1300 || failed=1 ;;
    # A message of 8 KB may not make an allocation above 64 MB (the layout walk's promise).
    ros) fuzz_one ros "${CM_FUZZ_ROS_RUNS:--1}" -max_len=8192 -malloc_limit_mb=64 || failed=1 ;;
    *) echo "fuzz.sh: unknown target '$t' (core, world, ros)" >&2; exit 2 ;;
  esac
done
exit "$failed"
