/// \file
/// Pair counts of the random sweeps, scaled by the environment (test_oracle_sweep,
/// test_ccd_backend, test_gjk_2d_sweep).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace oracle {

/// Pair count of a sweep scaled by the environment variable CM_SWEEP_SCALE (default 1; the
/// sanitizer build in CI runs 0.1), at least 20.
inline int scaled(int n) {
  const char* env = std::getenv("CM_SWEEP_SCALE");
  const double s = env != nullptr ? std::atof(env) : 1.0;
  return std::max(20, static_cast<int>(std::lround(n * (s > 0.0 ? s : 1.0))));
}

}  // namespace oracle
