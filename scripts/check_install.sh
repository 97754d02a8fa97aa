#!/usr/bin/env bash
# The installed package runs on its own: the demo launched from a catkin install space, in a clean
# environment (no source tree, no devel space on any path), on a master of its own. Called by
# scripts/test.sh after `catkin_make install`.
#   bash scripts/check_install.sh <install space>
set -euo pipefail
INSTALL="$(cd "$1" && pwd)"
LOG="$INSTALL.demo.log"
PORT=$(/usr/bin/python3 -c \
  'import socket; s = socket.socket(); s.bind(("", 0)); print(s.getsockname()[1])')
rc=0
# shellcheck disable=SC2016  # expanded by the inner shell, in the clean environment
env -i HOME="$HOME" PATH=/usr/bin:/bin LANG=C.UTF-8 ROS_HOME="$INSTALL/../ros_home_install" \
  ROS_MASTER_URI="http://localhost:$PORT" INSTALL="$INSTALL" PORT="$PORT" bash -c '
    source "$INSTALL/setup.bash"
    cd /
    timeout 120 roslaunch -p "$PORT" collision_monitor demo.launch duration:=8' >"$LOG" 2>&1 || rc=$?
if [ "$rc" -ne 0 ] || ! grep -q "monitoring .* bodies" "$LOG" ||
  ! grep -q "=== collision_monitor demo summary" "$LOG" || ! grep -q "^cycles: " "$LOG"; then
  tail -40 "$LOG"
  echo "check_install: the demo did not run from $INSTALL (exit $rc; log $LOG)" >&2
  exit 1
fi
echo "check_install: the demo ran from the install space ($(grep '^cycles: ' "$LOG"))"
