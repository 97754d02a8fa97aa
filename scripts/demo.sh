#!/usr/bin/env bash
# The main job: install dependencies, build, and launch the demo robot scene (headless; pass
# rviz:=true to open rviz, duration:=0 to run until Ctrl-C). Arguments go to roslaunch.
set -euo pipefail
source "$(dirname "$0")/env.sh"
bash "$CM_ROOT/scripts/install_deps.sh"
bash "$CM_ROOT/scripts/build.sh" -DCOLLISION_MONITOR_BENCHMARKS=OFF
cm_source_devel
exec roslaunch collision_monitor demo.launch "$@"
