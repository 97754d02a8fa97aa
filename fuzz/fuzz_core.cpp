/// \file
/// libFuzzer target for the geometry core: two shapes from any ConvexShape factory, two poses,
/// every query and both backends, checked as described in core_case.h. A failed check prints the
/// case and aborts, so libFuzzer saves the input (crash-<sha1>); copy it to fuzz/regressions/core/
/// and the replay gtest (test/robustness/test_fuzz_regressions.cpp) pins it.
#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include "core_case.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool print = std::getenv("CM_FUZZ_PRINT") != nullptr;
  if (print) {
    // Decode only (no queries) so that a crashing case can be read before it crashes.
    std::fprintf(stderr, "case: %s\n", cm_fuzz::describeCase(data, size).c_str());
  }
  const cm_fuzz::Outcome out = cm_fuzz::runCase(data, size);
  if (print) std::fprintf(stderr, "ok (%.3f ms)\n", 1e3 * out.seconds);
  if (!out.failure.empty()) {
    std::fprintf(stderr, "collision_monitor core fuzz check failed: %s\n", out.failure.c_str());
    std::abort();
  }
  return 0;
}
