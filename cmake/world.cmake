# ROS-free world model: bodies, broad phase, pair states, hysteresis, events.
# Links the geometry core only (no ROS headers, no catkin libraries).
add_library(collision_monitor_world
  src/world/broad_phase.cpp
  src/world/world_model.cpp
)
target_include_directories(collision_monitor_world PUBLIC
  $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>)
target_link_libraries(collision_monitor_world PUBLIC collision_monitor_core)
target_compile_options(collision_monitor_world PRIVATE ${CM_WARNING_FLAGS})

# Pure logic (status machine, events, time to collision, hash grid and sweep and prune on
# boxes): needs neither the GJK core nor ROS, so it is built from the sources directly against
# Eigen.
cm_add_gtest(test_world_logic
  SOURCES test/world/test_pair_logic.cpp test/world/test_broad_phase.cpp src/world/broad_phase.cpp
  LIBS Eigen3::Eigen)
if(TARGET test_world_logic)
  target_include_directories(test_world_logic PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/include)
endif()

# The world model end to end on real shapes through the GJK core: filters, hysteresis,
# staleness, compound bodies, broad phase vs brute force, services, time to collision.
cm_add_gtest(test_world_model
  SOURCES test/world/test_world_model.cpp
  LIBS collision_monitor_world)
