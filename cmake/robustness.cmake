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

# Soak test (issue #5): a roscpp load driver (1,000 bodies at 200 Hz, TF at 1 kHz, services in
# parallel, a collide/separate schedule it checks events and ~state against), run by
# test/robustness/soak.test (short, CI) and scripts/soak.sh [seconds] (long, by hand).
if(NOT COLLISION_MONITOR_CORE_ONLY AND CATKIN_ENABLE_TESTING)
  add_executable(collision_monitor_soak_driver test/robustness/soak_driver.cpp)
  target_include_directories(collision_monitor_soak_driver PRIVATE
    ${CATKIN_DEVEL_PREFIX}/${CATKIN_GLOBAL_INCLUDE_DESTINATION})
  target_include_directories(collision_monitor_soak_driver SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
  target_link_libraries(collision_monitor_soak_driver ${catkin_LIBRARIES})
  target_compile_options(collision_monitor_soak_driver PRIVATE ${CM_WARNING_FLAGS})
  add_dependencies(collision_monitor_soak_driver ${${PROJECT_NAME}_EXPORTED_TARGETS})
  if(NOT CM_STANDALONE)  # in a workspace: built by `make tests`, like the gtests
    set_target_properties(collision_monitor_soak_driver PROPERTIES EXCLUDE_FROM_ALL TRUE)
    add_dependencies(tests collision_monitor_soak_driver)
  endif()
endif()

# rostests over a real roscore (python test nodes in test/robustness, /usr/bin/python3).
if(NOT COLLISION_MONITOR_CORE_ONLY AND CATKIN_ENABLE_TESTING)
  find_package(rostest REQUIRED)
  file(GLOB CM_ROBUST_ROSTESTS RELATIVE ${CMAKE_CURRENT_SOURCE_DIR} test/robustness/*.test)
  foreach(t ${CM_ROBUST_ROSTESTS})
    # The node under TSan needs a build with it; valgrind does not run such a build.
    if((t MATCHES "/tsan\\.test$" AND NOT COLLISION_MONITOR_TSAN) OR
       (t MATCHES "/valgrind\\.test$" AND COLLISION_MONITOR_TSAN))
      continue()
    endif()
    add_rostest(${t} DEPENDENCIES collision_monitor_node collision_monitor_ros
      collision_monitor_soak_driver collision_monitor_generate_messages_py)
  endforeach()
  # The soak test loads both cores of a CI runner for ~45 s: alone, so that it neither disturbs
  # the timing figures of other tests nor gets its own figures disturbed by them.
  set(_cm_soak _ctest_${PROJECT_NAME}_rostest_test_robustness_soak.test)
  if(TEST ${_cm_soak})
    set_tests_properties(${_cm_soak} PROPERTIES RUN_SERIAL TRUE)
  endif()
  # roscore restarting under a running node (src/nodes/master_watch.h): not a rostest, the test
  # starts and restarts masters itself on a free port.
  catkin_run_tests_target(rosunit master_restart rosunit-master_restart.xml
    COMMAND "/usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/test/robustness/test_master_restart.py $<TARGET_FILE:collision_monitor_node> --gtest_output=xml:${CATKIN_TEST_RESULTS_DIR}/${PROJECT_NAME}/rosunit-master_restart.xml"
    DEPENDENCIES collision_monitor_node collision_monitor_ros collision_monitor_generate_messages_py)
  # The node and nodelet under ThreadSanitizer (COLLISION_MONITOR_TSAN builds only): ~45 s.
  set(_cm_tsan _ctest_${PROJECT_NAME}_rostest_test_robustness_tsan.test)
  if(TEST ${_cm_tsan})
    set_tests_properties(${_cm_tsan} PROPERTIES TIMEOUT 420
      ENVIRONMENT "CM_ROBOT_DATA=${CM_ROBOT_DATA_DIR}")
  endif()
  # The node under valgrind memcheck: ~20 s (node up in ~8 s, exit ~1 s after SIGINT). A node that
  # does not exit fails the test after 90 s (with thread states and stacks in the log); CTest's
  # limit is a backstop above rostest's time-limit (170 s). The Panda comes from CM_ROBOT_DATA, as
  # for the tests in test/ros.
  set(_cm_valgrind _ctest_${PROJECT_NAME}_rostest_test_robustness_valgrind.test)
  if(TEST ${_cm_valgrind})
    set_tests_properties(${_cm_valgrind} PROPERTIES TIMEOUT 300
      ENVIRONMENT "CM_ROBOT_DATA=${CM_ROBOT_DATA_DIR}")
  endif()
endif()


# Replays fuzz/regressions/ros and fuzz/corpus/ros with the ROS-input fuzzer's checks (g++; the
# libFuzzer target is fuzz/fuzz_ros_input.cpp, built by scripts/fuzz.sh).
if(NOT COLLISION_MONITOR_CORE_ONLY)
  cm_add_gtest(test_ros_fuzz_regressions
    SOURCES test/robustness/test_ros_fuzz_regressions.cpp
    LIBS collision_monitor_ros)
  if(TARGET test_ros_fuzz_regressions)
    target_include_directories(test_ros_fuzz_regressions PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/fuzz)
    target_include_directories(test_ros_fuzz_regressions SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
    target_compile_definitions(test_ros_fuzz_regressions PRIVATE
      CM_FUZZ_DIR="${CMAKE_CURRENT_SOURCE_DIR}/fuzz")
  endif()

  # The same for fuzz/regressions/world and fuzz/corpus/world with the world model's fuzzer
  # checks (fuzz/world_case.h; the libFuzzer target is fuzz/fuzz_world.cpp), and the check of
  # the reference's box and hull distances against test/core/oracle.h's qhull (called directly).
  cm_add_gtest(test_world_fuzz_regressions
    SOURCES test/robustness/test_world_fuzz_regressions.cpp
    LIBS collision_monitor_world Qhull::qhull_r)
  if(TARGET test_world_fuzz_regressions)
    target_include_directories(test_world_fuzz_regressions PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/fuzz
      ${CMAKE_CURRENT_SOURCE_DIR}/test/core)
    target_compile_definitions(test_world_fuzz_regressions PRIVATE
      CM_FUZZ_DIR="${CMAKE_CURRENT_SOURCE_DIR}/fuzz")
  endif()
endif()
