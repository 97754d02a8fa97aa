# Thin ROS layer: conversions, URDF/SRDF, mesh loading, the monitor (node + nodelet), rostests.
find_package(urdfdom REQUIRED)
find_package(urdfdom_headers REQUIRED)
find_package(tinyxml2 REQUIRED)
# log4cxx, rosconsole's back end: logger_services.cpp asks it for the loggers itself.
find_package(PkgConfig REQUIRED)
pkg_check_modules(LOG4CXX REQUIRED IMPORTED_TARGET liblog4cxx)

set(CM_ROS_SOURCES
  src/ros/conversions.cpp
  src/ros/wire_check.cpp
  src/ros/mesh_loader.cpp
  src/ros/robot_model.cpp
  src/ros/params.cpp
  src/ros/tunables.cpp
  src/ros/monitor.cpp
  src/ros/tf_receiver.cpp
  src/ros/nodelet.cpp
  src/ros/markers.cpp
  src/ros/logger_services.cpp
)

add_library(collision_monitor_ros ${CM_ROS_SOURCES})
target_include_directories(collision_monitor_ros PUBLIC
  $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
  $<BUILD_INTERFACE:${CATKIN_DEVEL_PREFIX}/${CATKIN_GLOBAL_INCLUDE_DESTINATION}>)
target_include_directories(collision_monitor_ros SYSTEM PUBLIC
  ${catkin_INCLUDE_DIRS} ${urdfdom_INCLUDE_DIRS}
  ${urdfdom_headers_INCLUDE_DIRS})
target_link_libraries(collision_monitor_ros PUBLIC
  collision_monitor_world collision_monitor_core ${catkin_LIBRARIES}
  ${urdfdom_LIBRARIES} tinyxml2::tinyxml2 PkgConfig::LOG4CXX)
target_compile_options(collision_monitor_ros PRIVATE ${CM_WARNING_FLAGS})
add_dependencies(collision_monitor_ros ${${PROJECT_NAME}_EXPORTED_TARGETS} ${catkin_EXPORTED_TARGETS})

add_executable(collision_monitor_node src/nodes/collision_monitor_node.cpp src/nodes/master_watch.cpp)
target_include_directories(collision_monitor_node SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(collision_monitor_node ${catkin_LIBRARIES})
target_compile_options(collision_monitor_node PRIVATE ${CM_WARNING_FLAGS})
# The node loads the nodelet from libcollision_monitor_ros at run time: build it first.
add_dependencies(collision_monitor_node collision_monitor_ros)

# The install space runs on its own (scripts/check_install.sh, CI): the three libraries the node
# and nodelet load (the core's install rule, with its CMake package, is in cmake/core.cmake), every
# header the ROS layer's headers include, the demo's files and scripts.
install(TARGETS collision_monitor_world collision_monitor_ros
  ARCHIVE DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION}
  RUNTIME DESTINATION ${CATKIN_GLOBAL_BIN_DESTINATION})
install(TARGETS collision_monitor_node RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
install(DIRECTORY include/collision_monitor/ DESTINATION ${CATKIN_PACKAGE_INCLUDE_DESTINATION})
install(FILES nodelet_plugins.xml DESTINATION ${CATKIN_PACKAGE_SHARE_DESTINATION})
install(DIRECTORY launch config urdf meshes rviz DESTINATION ${CATKIN_PACKAGE_SHARE_DESTINATION})
catkin_install_python(PROGRAMS scripts/demo_joint_motion.py scripts/demo_obstacles.py
  scripts/demo_summary.py DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
install(FILES scripts/demo_scene.py scripts/panda_demo_scene.py
  DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})

if(CATKIN_ENABLE_TESTING)
  find_package(rostest REQUIRED)
  # Real robot descriptions (example-robot-data): $CM_ROBOT_DATA at configure time, else
  # ../shared/data. Given to the tests as CM_ROBOT_DATA: CTest runs them through catkin's env
  # script, which resets ROS_PACKAGE_PATH (the launch files put it back for their nodes).
  if(DEFINED ENV{CM_ROBOT_DATA} AND NOT "$ENV{CM_ROBOT_DATA}" STREQUAL "")
    get_filename_component(CM_ROBOT_DATA_DIR "$ENV{CM_ROBOT_DATA}" ABSOLUTE)
  else()
    get_filename_component(CM_ROBOT_DATA_DIR "${CMAKE_CURRENT_SOURCE_DIR}/../shared/data" ABSOLUTE)
  endif()

  # Plain gtests, no master: conversions, validation, URDF/SRDF, parameters, mesh URIs.
  cm_add_gtest(test_ros_conversions
    SOURCES test/ros/test_conversions.cpp test/ros/test_robot_model.cpp
      test/ros/test_logger_services.cpp test/ros/test_tunables.cpp test/ros/test_tf_receiver.cpp
    LIBS collision_monitor_ros)
  if(TARGET test_ros_conversions)
    target_include_directories(test_ros_conversions SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
    target_compile_definitions(test_ros_conversions PRIVATE
      CM_SOURCE_DIR="${CMAKE_CURRENT_SOURCE_DIR}"
      CM_ROBOT_DATA="${CM_ROBOT_DATA_DIR}")
  endif()

  # Hostile-input defences, no master: the layout walkers behind Checked<M> (bounded
  # deserialization) and the length limits / bounded quoting of input strings. Its own binary: it
  # replaces the global operator new to measure allocations.
  cm_add_gtest(test_ros_wire_check
    SOURCES test/ros/test_wire_check.cpp
    LIBS collision_monitor_ros)
  if(TARGET test_ros_wire_check)
    target_include_directories(test_ros_wire_check SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
    target_compile_definitions(test_ros_wire_check PRIVATE
      CM_SOURCE_DIR="${CMAKE_CURRENT_SOURCE_DIR}")
  endif()

  # rostests over a real roscore (python test nodes in test/ros, run with /usr/bin/python3).
  file(GLOB CM_ROSTESTS RELATIVE ${CMAKE_CURRENT_SOURCE_DIR} test/ros/*.test)
  foreach(t ${CM_ROSTESTS})
    add_rostest(${t}
      DEPENDENCIES collision_monitor_node collision_monitor_ros collision_monitor_generate_messages_py)
    string(REPLACE "/" "_" _cm_test_name "${t}")
    set_tests_properties(_ctest_${PROJECT_NAME}_rostest_${_cm_test_name}
      PROPERTIES ENVIRONMENT "CM_ROBOT_DATA=${CM_ROBOT_DATA_DIR}")
  endforeach()
endif()
