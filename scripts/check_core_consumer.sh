#!/usr/bin/env bash
# A program without ROS (test/core_consumer) builds with plain CMake against the geometry core
# installed at a prefix (a catkin install space, or a core-only `cmake --install`): the CMake
# package collision_monitor_core, target collision_monitor::core, in a clean environment (env -i,
# no ROS variable). It must print the right distances, find the package in that prefix, and need
# no ROS, boost or log4cxx library (ldd: only the core, qhull, libccd and the C/C++ runtime).
# Called by scripts/test.sh after `catkin_make install` and after the core-only install.
#   bash scripts/check_core_consumer.sh <install prefix>
set -euo pipefail
CM_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
INSTALL="$(cd "$1" && pwd)"
BUILD="$INSTALL.core_consumer"
LOG="$BUILD.log"
rm -rf "$BUILD"
fail() {
  tail -40 "$LOG"
  echo "check_core_consumer: $1 (prefix $INSTALL; log $LOG)" >&2
  exit 1
}
rc=0
env -i HOME="$HOME" PATH=/usr/bin:/bin LANG=C.UTF-8 \
  cmake -S "$CM_ROOT/test/core_consumer" -B "$BUILD" -DCMAKE_PREFIX_PATH="$INSTALL" \
  -DCMAKE_BUILD_TYPE=Release >"$LOG" 2>&1 || rc=$?
[ "$rc" -eq 0 ] && { env -i HOME="$HOME" PATH=/usr/bin:/bin LANG=C.UTF-8 \
  cmake --build "$BUILD" >>"$LOG" 2>&1 || rc=$?; }
[ "$rc" -eq 0 ] || fail "the consumer did not configure or build (exit $rc)"
env -i HOME="$HOME" PATH=/usr/bin:/bin LANG=C.UTF-8 "$BUILD/cm_core_consumer" >>"$LOG" 2>&1 || rc=$?
if [ "$rc" -ne 0 ] || ! grep -q "^hull/sphere: Separated, distance 0.5 m" "$LOG" ||
  ! grep -q "^libccd at 0.4 m: intersect" "$LOG"; then
  fail "the consumer ran with wrong answers (exit $rc)"
fi
# The package came from this prefix, and nothing of catkin or ROS was looked up.
dir="$(sed -n 's/^collision_monitor_core_DIR:PATH=//p' "$BUILD/CMakeCache.txt")"
case "$dir" in
  "$INSTALL"/*) ;;
  *) fail "collision_monitor_core was found at '$dir', not in the prefix" ;;
esac
if grep -Eiq '^(catkin|roscpp|[a-z_]*ros[a-z_]*)_DIR:' "$BUILD/CMakeCache.txt"; then
  fail "the consumer's CMake cache names a ROS package: $(grep -Ei '^(catkin|roscpp|[a-z_]*ros[a-z_]*)_DIR:' "$BUILD/CMakeCache.txt" | head -3)"
fi
# Every library the program loads, transitively: the core (shared: from this prefix), qhull,
# libccd and the C/C++ runtime, nothing else.
libs="$(env -i PATH=/usr/bin:/bin ldd "$BUILD/cm_core_consumer")"
echo "$libs" >>"$LOG"
other="$(grep -Ev '^\s*(linux-vdso\.so|/lib64/ld-linux|lib(c|m|gcc_s|stdc\+\+|qhull_r|ccd)\.so)' <<<"$libs" |
  grep -v "^\s*libcollision_monitor_core\.so => $INSTALL/" || true)"
[ -z "$other" ] || fail "the consumer loads more than the core, qhull, libccd and the C++ runtime: $other"
if grep -Eiq 'ros|boost|log4cxx|console_bridge|catkin' <<<"$libs"; then
  fail "the consumer loads a ROS, boost or log4cxx library"
fi
if grep -q libcollision_monitor_core <<<"$libs"; then how="shared core"; else how="static core"; fi
echo "check_core_consumer: a plain CMake program built and ran against $INSTALL ($how; $(grep '^hull/sphere' "$LOG"); loads $(awk '{print $1}' <<<"$libs" | grep -v vdso | tr '\n' ' '))"
