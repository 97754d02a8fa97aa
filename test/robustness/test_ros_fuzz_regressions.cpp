// Replays every input of fuzz/regressions/ros (inputs that once failed the ROS-input fuzzer) and
// the seed corpus fuzz/corpus/ros through the fuzzer's own checks (fuzz/ros_input_case.h), built
// with g++ in the normal suite. Each regression file has a line in fuzz/regressions/ros/README.md
// on the bug it pins.
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "fuzz_inputs.h"
#include "ros_input_case.h"

namespace fs = std::filesystem;

namespace {

using cm_fuzz_inputs::bytes;
using cm_fuzz_inputs::inputs;

/// Every input's note (what became of it), by file name; each failure is a test failure.
std::map<std::string, std::string> replay(const std::string& dir) {
  std::map<std::string, std::string> notes;
  for (const fs::path& p : inputs(dir)) {
    const std::vector<std::uint8_t> data = bytes(p);
    const cm_fuzz_ros::Outcome out = cm_fuzz_ros::runRosInput(data.data(), data.size());
    EXPECT_EQ(out.failure, "") << p.filename().string();
    notes[p.filename().string()] = out.note;
  }
  return notes;
}

}  // namespace

TEST(RosFuzzRegressions, EveryFailedInputPasses) {
  const auto notes = replay(CM_FUZZ_DIR "/regressions/ros");
  // A 5e180 m ellipsoid 1e-46 m off a unit box's centre: its pair was UNKNOWN for good (the
  // query failed on an infinite support point); now checked.
  EXPECT_EQ(notes.at("body-ellipsoid-5e180m-support-overflow"),
            "body e added and checked: 1 pair(s)");
  // A 2.7e303 m box 1.797e308 m out, its end past the largest double: accepted, and its pair
  // with the unit box UNKNOWN for good; now refused at the door with the reason.
  EXPECT_EQ(notes.at("body-box-past-the-largest-double"),
            "addBody refused: body 'b' refused: part 0 reaches beyond the largest double (1.8e308 "
            "m) from the body origin");
}

TEST(RosFuzzRegressions, SeedCorpusReachesEveryInputKind) {
  // The seeds must reach the checks behind the door, not only the refusals
  // (fuzz/make_ros_seeds.py).
  const auto notes = replay(CM_FUZZ_DIR "/corpus/ros");
  EXPECT_EQ(notes.at("body-box"), "body b added and checked: 1 pair(s)");
  EXPECT_EQ(notes.at("body-convex"), "body h added and checked: 1 pair(s)");
  EXPECT_EQ(notes.at("body-remove"), "operation 1");
  EXPECT_EQ(notes.at("poses-two"), "2 pose update(s)");
  EXPECT_EQ(notes.at("check-box"), "check_collision: 1 pair(s)");
  EXPECT_EQ(notes.at("urdf-three-links"), "URDF: 2 bodies, 1 elements refused");
  EXPECT_EQ(notes.at("srdf-rules"), "SRDF: 1 disabled, 1 skipped");
  EXPECT_EQ(notes.at("xmlrpc-body"), "body wand added and checked: 1 pair(s)");
}
