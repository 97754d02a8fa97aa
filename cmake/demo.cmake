# Demo robot scene: the marker builder's unit test (plain gtest, no master), the launch-level
# rostest of the demo scene and the rviz screenshot check (Xvfb + software GL + ImageMagick).
if(NOT CATKIN_ENABLE_TESTING)
  return()
endif()

# MarkerBuilder against the real world model and core (linked from the node library, which holds
# the message conversions it uses).
cm_add_gtest(test_markers
  SOURCES test/demo/test_markers.cpp
  LIBS collision_monitor_ros)
if(TARGET test_markers)
  target_include_directories(test_markers SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
  add_dependencies(test_markers ${catkin_EXPORTED_TARGETS})
endif()

find_package(rostest REQUIRED)
# Python test nodes in test/demo run with /usr/bin/python3 and import the generated messages.
set(CM_DEMO_TEST_DEPS collision_monitor_node collision_monitor_ros
  collision_monitor_generate_messages_py)
if(TARGET collision_monitor_node)
  # The demo scene: designed WARNING_BEGIN, COLLISION_BEGIN and COLLISION_END on named pairs.
  add_rostest(test/demo/demo_events.test DEPENDENCIES ${CM_DEMO_TEST_DEPS})
  # rviz under Xvfb with software GL: red in a screenshot during a collision, green when clear.
  # Screenshots go to $CM_ARTIFACTS if set, else to <build>/test_results (demo_screenshot.png).
  add_rostest(test/demo/demo_screenshot.test DEPENDENCIES ${CM_DEMO_TEST_DEPS})
  set_tests_properties(_ctest_${PROJECT_NAME}_rostest_test_demo_demo_screenshot.test PROPERTIES
    ENVIRONMENT "CM_DEMO_ARTIFACTS=${CMAKE_BINARY_DIR}/test_results")
  # The demo's summary (scripts/demo_summary.py) fed by the test: what it prints.
  add_rostest(test/demo/demo_summary.test DEPENDENCIES ${CM_DEMO_TEST_DEPS})
  # The Panda demo (launch/panda_demo.launch): every event with an obstacle against the test's
  # own forward kinematics and closed-form distances. The Panda comes from CM_ROBOT_DATA
  # (cmake/ros.cmake).
  add_rostest(test/demo/panda_demo.test DEPENDENCIES ${CM_DEMO_TEST_DEPS})
  set_tests_properties(_ctest_${PROJECT_NAME}_rostest_test_demo_panda_demo.test PROPERTIES
    ENVIRONMENT "CM_ROBOT_DATA=${CM_ROBOT_DATA_DIR}")
endif()
