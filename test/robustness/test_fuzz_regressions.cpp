// Replays every input of fuzz/regressions/core (inputs that once failed the geometry-core fuzzer:
// crashes, hangs, wrong answers) and the seed corpus fuzz/corpus/core through the fuzzer's own
// checks (fuzz/core_case.h), built with g++ in the normal suite. Each regression file has a line
// in fuzz/regressions/core/README.md on the bug it pins.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "core_case.h"
#include "fuzz_inputs.h"

namespace fs = std::filesystem;

namespace {

using cm_fuzz_inputs::bytes;
using cm_fuzz_inputs::inputs;

struct Tally {
  int files = 0, checked = 0, oracle = 0, overlap = 0, unconverged = 0, refused = 0;
  double slowest = 0.0;
  std::vector<std::string> not_checked;  ///< inputs only replayed (refused or out of domain)
};

Tally replay(const std::string& dir) {
  Tally t;
  for (const fs::path& p : inputs(dir)) {
    const std::vector<std::uint8_t> data = bytes(p);
    const cm_fuzz::Outcome out = cm_fuzz::runCase(data.data(), data.size());
    EXPECT_EQ(out.failure, "") << p.filename().string();
    ++t.files;
    t.checked += out.checked;
    t.oracle += out.oracle;
    t.overlap += out.checked && out.overlap;
    t.unconverged += out.unconverged;
    t.refused += !out.checked;
    if (!out.checked) t.not_checked.push_back(p.filename().string());
    t.slowest = std::max(t.slowest, out.seconds);
  }
  std::printf(
      "%s: %d inputs, %d checked (%d against the exact oracle, %d overlapping, %d "
      "unconverged EPA on curved cores), %d refused or out of domain, slowest %.1f ms\n",
      dir.c_str(), t.files, t.checked, t.oracle, t.overlap, t.unconverged, t.refused,
      1e3 * t.slowest);
  return t;
}

}  // namespace

TEST(FuzzRegressions, EveryCrashInputPasses) {
  const Tally t = replay(CM_FUZZ_DIR "/regressions/core");
  // Regression inputs are only ever added (83 on 2026-12-03).
  EXPECT_GE(t.files, 83) << "regression inputs lost from " CM_FUZZ_DIR "/regressions/core";
  // Every one is checked in the fuzzer's domain, not only replayed for crashes, but these (a
  // change to the domain that left more out would make their checks silently crash-only).
  EXPECT_EQ(t.not_checked, (std::vector<std::string>{"gjk-flat-wide-cone-out-of-domain",
                                                     "libccd-segv-8e165m-box-by-subnormal-box",
                                                     "libccd-segv-point-3e151m-from-cylinder"}));
}

TEST(FuzzRegressions, SeedCorpusPassesAndIsMeaningful) {
  const Tally t = replay(CM_FUZZ_DIR "/corpus/core");
  ASSERT_GE(t.files, 300);
  // The seeds must exercise the checks, not only the refusals: most are in the checked domain,
  // a good share against the exact oracle, with both overlapping and separated pairs.
  EXPECT_GE(t.checked, t.files / 2);
  EXPECT_GE(t.oracle, t.checked / 5);
  EXPECT_GE(t.overlap, t.checked / 5);
  EXPECT_LE(t.overlap, 4 * t.checked / 5);
}
