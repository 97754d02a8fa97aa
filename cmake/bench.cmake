# Google Benchmark suites (bench/). Benchmarks are not tests: nothing here is added to CTest.
# Results and how to reproduce them: docs/benchmarks.md (scripts/bench.sh builds build-bench/ and
# runs the suite). The competitors are optional: a missing FCL or Bullet drops only that
# competitor (with a message); libccd is always there (the core itself links it).
#
# The benchmarks are meant for an optimised build: CMAKE_BUILD_TYPE Release gives -O3 -DNDEBUG
# with GCC; any other build type prints a warning (numbers from -O0 builds are meaningless).

find_package(benchmark QUIET)
if(NOT benchmark_FOUND)
  message(STATUS "collision_monitor: Google Benchmark not found (libbenchmark-dev): no bench/ targets")
  return()
endif()
if(NOT CMAKE_BUILD_TYPE MATCHES "^(Release|RelWithDebInfo)$")
  message(WARNING "collision_monitor: benchmarks built with CMAKE_BUILD_TYPE='${CMAKE_BUILD_TYPE}'; "
                  "use Release for meaningful numbers")
endif()

# FCL 0.7 (libfcl-dev): its libccd-based GJK solver is a competitor.
find_package(fcl QUIET)
if(TARGET fcl)
  set(CM_BENCH_FCL_TARGET fcl)
elseif(TARGET fcl::fcl)
  set(CM_BENCH_FCL_TARGET fcl::fcl)
else()
  message(STATUS "collision_monitor: FCL not found (libfcl-dev): benchmarks run without the FCL competitor")
endif()

# FCL as a competitor of `target`, when found. Competitor headers are not ours: keep their
# warnings out of -Werror by treating their include directories as system headers.
function(cm_bench_with_fcl target)
  if(CM_BENCH_FCL_TARGET)
    target_link_libraries(${target} PRIVATE ${CM_BENCH_FCL_TARGET})
    target_compile_definitions(${target} PRIVATE CM_BENCH_HAVE_FCL=1)
  endif()
  set_target_properties(${target} PROPERTIES NO_SYSTEM_FROM_IMPORTED OFF)
endfunction()

# Bullet 3 (libbullet-dev), double precision: the *-float64 libraries with BT_USE_DOUBLE_PRECISION
# (pkg-config bullet-float64 carries both). Mixing the float libraries with double headers would
# silently break the ABI, so only the float64 variant is accepted.
pkg_check_modules(CM_BULLET64 QUIET IMPORTED_TARGET bullet-float64)
if(NOT CM_BULLET64_FOUND)
  message(STATUS "collision_monitor: Bullet float64 (libbullet-dev, pkg-config bullet-float64) not found: "
                 "benchmarks run without the Bullet competitor")
endif()

add_executable(collision_monitor_bench_core
  bench/bench_core.cpp
  bench/pools.cpp
)
target_link_libraries(collision_monitor_bench_core PRIVATE
  collision_monitor_core benchmark::benchmark PkgConfig::CCD Eigen3::Eigen)
target_compile_options(collision_monitor_bench_core PRIVATE ${CM_WARNING_FLAGS})
cm_bench_with_fcl(collision_monitor_bench_core)  # Bullet's headers are system headers too
if(CM_BULLET64_FOUND)
  target_link_libraries(collision_monitor_bench_core PRIVATE PkgConfig::CM_BULLET64)
  target_compile_definitions(collision_monitor_bench_core PRIVATE CM_BENCH_HAVE_BULLET=1)
endif()

# Instruction-count driver for callgrind (scripts/icount.sh): not a benchmark, no competitors.
add_executable(collision_monitor_icount bench/icount.cpp bench/pools.cpp)
target_link_libraries(collision_monitor_icount PRIVATE
  collision_monitor_core PkgConfig::CCD Eigen3::Eigen)
target_compile_options(collision_monitor_icount PRIVATE ${CM_WARNING_FLAGS})

# Node-level benchmark (world update + check cycle): needs the world model, so only in the full
# build, and only once src/world/world_model.cpp exists.
if(TARGET collision_monitor_world AND EXISTS "${CMAKE_CURRENT_SOURCE_DIR}/bench/bench_world.cpp")
  add_executable(collision_monitor_bench_world bench/bench_world.cpp)
  target_link_libraries(collision_monitor_bench_world PRIVATE
    collision_monitor_world collision_monitor_core benchmark::benchmark Eigen3::Eigen)
  target_compile_options(collision_monitor_bench_world PRIVATE ${CM_WARNING_FLAGS})
  cm_bench_with_fcl(collision_monitor_bench_world)
endif()

# Robot self-collision cycle (the real robots of example-robot-data, loaded the node's way): needs
# the ROS layer's URDF/SRDF and mesh loading (no master).
if(TARGET collision_monitor_ros AND EXISTS "${CMAKE_CURRENT_SOURCE_DIR}/bench/bench_robot.cpp")
  if(DEFINED ENV{CM_ROBOT_DATA} AND NOT "$ENV{CM_ROBOT_DATA}" STREQUAL "")
    get_filename_component(CM_BENCH_ROBOT_DATA "$ENV{CM_ROBOT_DATA}" ABSOLUTE)
  else()
    get_filename_component(CM_BENCH_ROBOT_DATA "${CMAKE_CURRENT_SOURCE_DIR}/../shared/data" ABSOLUTE)
  endif()
  add_executable(collision_monitor_bench_robot bench/bench_robot.cpp)
  target_link_libraries(collision_monitor_bench_robot PRIVATE
    collision_monitor_ros benchmark::benchmark Eigen3::Eigen)
  target_compile_definitions(collision_monitor_bench_robot PRIVATE
    CM_BENCH_ROBOT_DATA="${CM_BENCH_ROBOT_DATA}")
  target_compile_options(collision_monitor_bench_robot PRIVATE ${CM_WARNING_FLAGS})
  add_dependencies(collision_monitor_bench_robot ${${PROJECT_NAME}_EXPORTED_TARGETS})
  cm_bench_with_fcl(collision_monitor_bench_robot)
endif()

# End-to-end latency probe (bench/latency.launch, scripts/bench_latency.sh): a roscpp node that
# drives collision_monitor_node over loopback. Needs the ROS layer (full build).
if(TARGET collision_monitor_ros AND EXISTS "${CMAKE_CURRENT_SOURCE_DIR}/bench/latency_probe.cpp")
  add_executable(collision_monitor_latency_probe bench/latency_probe.cpp)
  target_include_directories(collision_monitor_latency_probe PRIVATE
    ${CATKIN_DEVEL_PREFIX}/${CATKIN_GLOBAL_INCLUDE_DESTINATION})
  target_include_directories(collision_monitor_latency_probe SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
  target_link_libraries(collision_monitor_latency_probe ${catkin_LIBRARIES})
  target_compile_options(collision_monitor_latency_probe PRIVATE ${CM_WARNING_FLAGS})
  add_dependencies(collision_monitor_latency_probe ${${PROJECT_NAME}_EXPORTED_TARGETS})
endif()
