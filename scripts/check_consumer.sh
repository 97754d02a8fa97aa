#!/usr/bin/env bash
# A downstream package (test/consumer: C++14 asked for, messages, services and the geometry core)
# builds against a catkin install space of collision_monitor with only what catkin exports, and
# runs; rospy imports the messages. Called by scripts/test.sh after `catkin_make install`.
#   bash scripts/check_consumer.sh <install space>
set -euo pipefail
CM_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
INSTALL="$(cd "$1" && pwd)"
WS="$INSTALL/../consumer_ws"
LOG="$INSTALL/../consumer_ws.log"
rm -rf "$WS"
mkdir -p "$WS/src"
ln -sfn "$CM_ROOT/test/consumer" "$WS/src/cm_consumer_check"
rc=0
# shellcheck disable=SC2016  # expanded by the inner shell, in the clean environment
env -i HOME="$HOME" PATH=/usr/bin:/bin LANG=C.UTF-8 INSTALL="$INSTALL" WS="$WS" bash -c '
    source "$INSTALL/setup.bash"
    cd "$WS" && catkin_make -DPYTHON_EXECUTABLE=/usr/bin/python3 &&
    source devel/setup.bash &&
    devel/lib/cm_consumer_check/cm_consumer_check &&
    /usr/bin/python3 -c "from collision_monitor.msg import Body; from collision_monitor.srv import GetDistance; print(\"rospy: ok\")"' \
  >"$LOG" 2>&1 || rc=$?
if [ "$rc" -ne 0 ] || ! grep -q "^capsule/box: Separated, distance 0.35" "$LOG" || ! grep -q "^rospy: ok" "$LOG"; then
  tail -40 "$LOG"
  echo "check_consumer: a downstream package did not build or run against $INSTALL (exit $rc; log $LOG)" >&2
  exit 1
fi
echo "check_consumer: a downstream package built and ran against the install space ($(grep '^capsule/box' "$LOG"))"
