#!/usr/bin/env bash
# Geometry-core fuzzing with libFuzzer (clang, ASan + UBSan), in its own build folder.
#   bash scripts/fuzz.sh [seconds]      # default 60; longer by hand, e.g. 3600 (scripts/test.sh,
#                                       # the CI run: 1200 inputs, seed 1, at most 120 s)
# CM_FUZZ_SEED: libFuzzer's -seed (default 0: a new random seed each run). CI (scripts/test.sh)
# fixes it, so that a CI failure is one a later run reproduces rather than a new random finding;
# exploration is the job of the longer runs by hand.
# CM_FUZZ_RUNS: stop after this many inputs (libFuzzer -runs; default: none, time only). With a
# fixed seed and an empty corpus (a clean clone) the run is then the same on every machine.
# Steps: build fuzz/ with clang in $CM_FUZZ_BUILD (default build-fuzz), replay every committed
# crash input (fuzz/regressions/core) and the seed corpus, then fuzz for <seconds> from the seeds
# (new inputs go to $CM_FUZZ_BUILD/corpus-core, never into the repository). A failing input is
# saved as $CM_FUZZ_BUILD/artifacts/crash-*: copy it into fuzz/regressions/core/ (the replay gtest
# test_fuzz_regressions then pins it in the normal suite). Exit code non-zero on any failure.
set -euo pipefail
source "$(dirname "$0")/env.sh"
SECONDS_TO_RUN="${1:-60}"
B="${CM_FUZZ_BUILD:-$CM_ROOT/build-fuzz}"
JOBS="${CM_FUZZ_JOBS:-1}"
CXX=clang++ CC=clang cmake -S "$CM_ROOT/fuzz" -B "$B" -DCMAKE_BUILD_TYPE=RelWithDebInfo >"$B.configure.log" 2>&1 \
  || { cat "$B.configure.log"; exit 1; }
cmake --build "$B" -j"$(nproc)" --target fuzz_core
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:${ASAN_OPTIONS:-}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:${UBSAN_OPTIONS:-}"
mkdir -p "$B/corpus-core" "$B/artifacts"

echo "fuzz.sh: replaying fuzz/regressions/core and the seed corpus"
mapfile -t INPUTS < <(find "$CM_ROOT/fuzz/regressions/core" "$CM_ROOT/fuzz/corpus/core" -type f ! -name '*.md' | sort)
"$B/fuzz_core" -runs=0 "${INPUTS[@]}" >"$B/replay.log" 2>&1 || { tail -40 "$B/replay.log"; exit 1; }
echo "fuzz.sh: ${#INPUTS[@]} inputs replayed"

echo "fuzz.sh: fuzzing for ${SECONDS_TO_RUN} s"
rc=0
PARALLEL=()
if [ "$JOBS" -gt 1 ]; then PARALLEL=(-fork="$JOBS"); fi
(cd "$B" && ./fuzz_core "$B/corpus-core" "$CM_ROOT/fuzz/corpus/core" "${PARALLEL[@]}" \
  -seed="${CM_FUZZ_SEED:-0}" -runs="${CM_FUZZ_RUNS:--1}" -max_total_time="$SECONDS_TO_RUN" -timeout=10 -rss_limit_mb=2048 -max_len=2048 \
  -artifact_prefix="$B/artifacts/" -print_final_stats=1 >"$B/fuzz.log" 2>&1) || rc=$?
grep -E "^stat::(number_of_executed_units|average_exec_per_sec|peak_rss_mb)|^#[0-9]+.*DONE" "$B/fuzz.log" || true
if [ "$rc" -ne 0 ]; then
  grep -A30 -E "check failed|ERROR: (AddressSanitizer|libFuzzer)|runtime error|SUMMARY" "$B/fuzz.log" | head -60
  echo "fuzz.sh: FAILED; inputs: $(ls "$B/artifacts")" >&2
  exit "$rc"
fi
echo "fuzz.sh: ok ($(ls "$B/corpus-core" | wc -l) corpus entries in $B/corpus-core)"
