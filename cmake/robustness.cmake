# Robustness: crash-corpus replay of the geometry-core fuzzer, hostile inputs and resource limits
# of the core (plain gtests), and the ROS-level hostile-input, fault and soak rostests.
# The libFuzzer build itself is fuzz/CMakeLists.txt (clang), driven by scripts/fuzz.sh.

# Replays fuzz/regressions/core and fuzz/corpus/core with the fuzzer's checks (g++).
cm_add_gtest(test_fuzz_regressions
  SOURCES test/robustness/test_fuzz_regressions.cpp
  LIBS collision_monitor_core Qhull::qhull_r)
if(TARGET test_fuzz_regressions)
  target_include_directories(test_fuzz_regressions PRIVATE
    ${CMAKE_CURRENT_SOURCE_DIR}/fuzz ${CMAKE_CURRENT_SOURCE_DIR}/test/core)
  target_compile_definitions(test_fuzz_regressions PRIVATE
    CM_FUZZ_DIR="${CMAKE_CURRENT_SOURCE_DIR}/fuzz")
endif()

# Hostile values straight into the core (NaN poses, degenerate cores, libccd on both) and the
# resource figures of big hulls (1e6 points: time and memory measured, see docs/reliability.md).
cm_add_gtest(test_core_hostile
  SOURCES test/robustness/test_core_hostile.cpp
  LIBS collision_monitor_core)

# rostests over a real roscore (python test nodes in test/robustness, /usr/bin/python3).
if(NOT COLLISION_MONITOR_CORE_ONLY AND CATKIN_ENABLE_TESTING)
  find_package(rostest REQUIRED)
  file(GLOB CM_ROBUST_ROSTESTS RELATIVE ${CMAKE_CURRENT_SOURCE_DIR} test/robustness/*.test)
  foreach(t ${CM_ROBUST_ROSTESTS})
    add_rostest(${t} DEPENDENCIES collision_monitor_node collision_monitor_ros)
  endforeach()
endif()
