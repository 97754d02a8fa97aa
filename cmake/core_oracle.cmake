# qhull hull tests, exact-oracle random sweeps and the libccd backend tests.
# test/core/oracle.h calls qhull directly (independent of src/core), hence Qhull::qhull_r.
cm_add_gtest(test_convex_hull
  SOURCES test/core/test_convex_hull.cpp
  LIBS collision_monitor_core Qhull::qhull_r)

# Fixed-seed sweeps of >= 100k pairs against the oracle. CM_SWEEP_SCALE (default 1.0) scales the
# pair counts (the sanitizer CI job runs 0.1).
cm_add_gtest(test_oracle_sweep
  SOURCES test/core/test_oracle_sweep.cpp
  LIBS collision_monitor_core Qhull::qhull_r)

# 2D (footprints): its own oracle (a long double hull of A - B), no qhull.
cm_add_gtest(test_gjk_2d_sweep
  SOURCES test/core/test_gjk_2d_sweep.cpp
  LIBS collision_monitor_core)

cm_add_gtest(test_ccd_backend
  SOURCES test/core/test_ccd_backend.cpp
  LIBS collision_monitor_core Qhull::qhull_r PkgConfig::CCD)
