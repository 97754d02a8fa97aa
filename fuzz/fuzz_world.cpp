/// \file
/// libFuzzer target for the world model: settings, bodies of spheres, capsules, boxes or convex
/// hulls and a sequence of operations (poses, checks, replacements, removals, queries), every
/// check held to the contract as world_case.h describes. A failed check prints the operations
/// and aborts, so libFuzzer saves the input (crash-<sha1>); copy it to fuzz/regressions/world/
/// and the replay gtest (test/robustness/test_world_fuzz_regressions.cpp) pins it.
#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include "world_case.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const cm_fuzz_world::Outcome out = cm_fuzz_world::runCase(data, size);
  if (!out.failure.empty()) {
    std::fprintf(stderr, "collision_monitor world fuzz check failed: %s\n", out.failure.c_str());
    std::abort();
  }
  return 0;
}
