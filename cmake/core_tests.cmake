# Exact-answer, shape, dimension and warm-start tests of the geometry core, and the example
# program (the temporary "main job" until the demo exists).
cm_add_gtest(test_core_shapes SOURCES test/core/test_shapes.cpp LIBS collision_monitor_core)
cm_add_gtest(test_core_gjk_exact SOURCES test/core/test_gjk_exact.cpp LIBS collision_monitor_core)
cm_add_gtest(test_core_gjk_dimensions SOURCES test/core/test_gjk_dimensions.cpp
             LIBS collision_monitor_core)
cm_add_gtest(test_core_warm_start SOURCES test/core/test_warm_start.cpp LIBS collision_monitor_core)

if(NOT COLLISION_MONITOR_CORE_ONLY OR BUILD_TESTING)
  add_executable(collision_monitor_example examples/print_distances.cpp)
  target_link_libraries(collision_monitor_example collision_monitor_core)
  target_compile_options(collision_monitor_example PRIVATE ${CM_WARNING_FLAGS})
endif()
