# ROS-free geometry core. Depends on Eigen, qhull and libccd only.
add_library(collision_monitor_core
  src/core/convex_hull.cpp
  src/core/convex_shape.cpp
  src/core/query.cpp
  src/core/ccd_backend.cpp
  src/core/backend.cpp
)
target_include_directories(collision_monitor_core PUBLIC
  $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>)
target_link_libraries(collision_monitor_core PUBLIC Eigen3::Eigen PRIVATE Qhull::qhull_r PkgConfig::CCD)
target_compile_options(collision_monitor_core PRIVATE ${CM_WARNING_FLAGS})

include(cmake/core_tests.cmake)    # exact-answer, shape, dimension and warm-start tests
include(cmake/core_oracle.cmake)   # qhull hull tests, exact-oracle random sweeps, libccd backend
