/// \file
/// libFuzzer target for the ROS layer's untrusted input (`~bodies`, `~body_poses`,
/// `~check_collision`, URDF, SRDF, the `~bodies` parameter), checked as described in
/// ros_input_case.h. A failed check prints the input's kind and the reason and aborts, so libFuzzer
/// saves the input (crash-<sha1>); copy it to fuzz/regressions/ros/ (with a line in its README) and
/// test_ros_fuzz_regressions pins it. CM_FUZZ_PRINT=1 prints what became of each input.
#include <console_bridge/console.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include "ros_input_case.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // urdfdom reports every refused URDF through console_bridge, on stderr: millions of lines.
  if (std::getenv("CM_FUZZ_PRINT") == nullptr) {
    console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_NONE);
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool print = std::getenv("CM_FUZZ_PRINT") != nullptr;
  const cm_fuzz_ros::Outcome out = cm_fuzz_ros::runRosInput(data, size);
  if (print) std::fprintf(stderr, "%s\n", out.note.c_str());
  if (!out.failure.empty()) {
    std::fprintf(stderr, "collision_monitor ROS input fuzz check failed: %s\n",
                 out.failure.c_str());
    std::abort();
  }
  return 0;
}
