# Sourced by the scripts: where things are, and the ROS environment of a standalone build.
# shellcheck shell=bash
CM_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
CM_BUILD="${CM_BUILD:-$CM_ROOT/build}"
# Real robot descriptions (Franka Panda, PR2) used by tests and benchmarks.
CM_ROBOT_DATA="${CM_ROBOT_DATA:-$CM_ROOT/../shared/data}"
# A pyenv python3 may shadow the system one; catkin needs Debian's python3 with catkin_pkg.
# shellcheck disable=SC2034  # read by the scripts that source this file
CM_PYTHON=/usr/bin/python3
cm_source_devel() {
  set +u
  # shellcheck disable=SC1091  # written by the build
  source "$CM_BUILD/devel/setup.bash"
  set -u
  if [ -d "$CM_ROBOT_DATA" ]; then
    local data
    data="$(cd "$CM_ROBOT_DATA" && pwd)"
    export ROS_PACKAGE_PATH="$ROS_PACKAGE_PATH:$data"
  fi
  export ROS_HOME="${ROS_HOME:-$CM_BUILD/ros_home}"
  export PATH="/usr/bin:$PATH"
}
# ccache: paths under the package are hashed relative to it, and the working directory is left out
# of the hash. By default ccache hashes the build folder into every object built with -g (the
# ASan, fuzz and TSan builds), so a clone at another path (a CI runner's) found none of them.
export CCACHE_BASEDIR="$CM_ROOT"
export CCACHE_NOHASHDIR=1
