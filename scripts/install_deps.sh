#!/usr/bin/env bash
# Installs every Debian 12 package the build, the demo and the tests need (ROS 1 from Debian).
set -euo pipefail
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
PACKAGES=(
  build-essential cmake pkg-config git ccache
  # ROS 1 (Debian packages, no /opt/ros)
  ros-base-dev catkin python3-catkin-pkg python3-rospkg rosbash rosout
  ros-message-generation ros-message-runtime
  python3-rostest python3-rospy python3-roslaunch python3-rostopic python3-rosservice
  python3-tf2-ros python3-visualization-msgs python3-diagnostic-msgs python3-sensor-msgs
  libtf2-ros-dev libtf2-msgs-dev libtf2-eigen-dev libtf2-geometry-msgs-dev
  libnodeletlib-dev libnodelet-dev pluginlib-dev liblog4cxx-dev
  libdiagnostic-updater-dev libvisualization-msgs-dev
  libdynamic-reconfigure-config-init-mutex-dev python3-dynamic-reconfigure
  ros-robot-state-publisher librobot-state-publisher-dev joint-state-publisher
  # geometry and robot models
  libeigen3-dev libqhull-dev libccd-dev liburdfdom-dev liburdfdom-headers-dev libtinyxml2-dev
  libgeometric-shapes-dev libresource-retriever-dev libassimp-dev
  # tests, benchmarks (FCL and Bullet are compared against), visual checks
  libgtest-dev googletest libbenchmark-dev libfcl-dev libbullet-dev
  # the contract sweep's independent oracle (qhull through scipy)
  python3-numpy python3-scipy
  rviz xvfb imagemagick clang-format
  # static analysis (scripts/tidy.sh; scripts/lint.sh)
  clang-tidy shellcheck python3-pyflakes
  # fuzzing (scripts/fuzz.sh): clang with libFuzzer and the sanitizer runtimes; valgrind (node leak check)
  clang libclang-rt-14-dev valgrind
)
if [ "${CM_SKIP_APT_UPDATE:-0}" != "1" ]; then
  $SUDO apt-get update -qq
fi
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${PACKAGES[@]}" >/dev/null
echo "install_deps: ${#PACKAGES[@]} packages present"
