#!/usr/bin/env bash
# The main job: install dependencies, build, and launch the demo robot scene (headless; pass
# rviz:=true to open rviz, duration:=0 to run until Ctrl-C). Arguments go to roslaunch.
# `bash scripts/demo.sh panda [args]` launches the Franka Panda demo (launch/panda_demo.launch)
# instead; its robot comes from $CM_ROBOT_DATA, else ../shared/data beside the package.
set -euo pipefail
source "$(dirname "$0")/env.sh"
LAUNCH=demo.launch
if [ "${1:-}" = panda ]; then
  LAUNCH=panda_demo.launch
  shift
  export CM_ROBOT_DATA
fi
bash "$CM_ROOT/scripts/install_deps.sh"
bash "$CM_ROOT/scripts/build.sh" -DCOLLISION_MONITOR_BENCHMARKS=OFF
cm_source_devel
exec roslaunch collision_monitor "$LAUNCH" "$@"
