/// \file
/// The inputs of a fuzzer's folder (fuzz/regressions/<target>, fuzz/corpus/<target>) for the
/// replay gtests: test_fuzz_regressions, test_world_fuzz_regressions, test_ros_fuzz_regressions.
#pragma once

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace cm_fuzz_inputs {

/// Every file of `dir` but its README.md, sorted; none when `dir` is missing.
inline std::vector<std::filesystem::path> inputs(const std::string& dir) {
  std::vector<std::filesystem::path> out;
  if (!std::filesystem::is_directory(dir)) return out;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.is_regular_file() && e.path().extension() != ".md") out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

inline std::vector<std::uint8_t> bytes(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(f), {});
}

}  // namespace cm_fuzz_inputs
