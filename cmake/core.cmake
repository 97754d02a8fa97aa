# ROS-free geometry core. Depends on Eigen, qhull and libccd only.
add_library(collision_monitor_core
  src/core/convex_hull.cpp
  src/core/convex_shape.cpp
  src/core/query.cpp
  src/core/ccd_backend.cpp
  src/core/backend.cpp
)
add_library(collision_monitor::core ALIAS collision_monitor_core)
# Installed, it is collision_monitor::core of the CMake package collision_monitor_core (below).
set_target_properties(collision_monitor_core PROPERTIES EXPORT_NAME core)
target_include_directories(collision_monitor_core PUBLIC
  $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
  $<INSTALL_INTERFACE:include>)
target_compile_features(collision_monitor_core PUBLIC cxx_std_17)  # the headers need C++17
target_link_libraries(collision_monitor_core PUBLIC Eigen3::Eigen PRIVATE Qhull::qhull_r PkgConfig::CCD)
target_compile_options(collision_monitor_core PRIVATE ${CM_WARNING_FLAGS})

# Installed as the CMake package collision_monitor_core, for programs without ROS:
#   find_package(collision_monitor_core REQUIRED)
#   target_link_libraries(app PRIVATE collision_monitor::core)
# Core-only build: `cmake --install` installs the library, include/collision_monitor/core and the
# package. Catkin build: the library goes where catkin puts libraries (lib/, the headers with the
# rest by cmake/ros.cmake), the package beside it, so a catkin install space serves both kinds of
# users (scripts/check_core_consumer.sh checks both in CI).
if(COLLISION_MONITOR_CORE_ONLY)
  include(GNUInstallDirs)
  set(CM_CORE_LIB_DESTINATION ${CMAKE_INSTALL_LIBDIR})
  set(CM_CORE_BIN_DESTINATION ${CMAKE_INSTALL_BINDIR})
  install(DIRECTORY include/collision_monitor/core/
    DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/collision_monitor/core)
else()
  set(CM_CORE_LIB_DESTINATION ${CATKIN_PACKAGE_LIB_DESTINATION})
  set(CM_CORE_BIN_DESTINATION ${CATKIN_GLOBAL_BIN_DESTINATION})
endif()
set(CM_CORE_CONFIG_DESTINATION ${CM_CORE_LIB_DESTINATION}/cmake/collision_monitor_core)
install(TARGETS collision_monitor_core EXPORT collision_monitor_coreTargets
  ARCHIVE DESTINATION ${CM_CORE_LIB_DESTINATION}
  LIBRARY DESTINATION ${CM_CORE_LIB_DESTINATION}
  RUNTIME DESTINATION ${CM_CORE_BIN_DESTINATION})
install(EXPORT collision_monitor_coreTargets NAMESPACE collision_monitor::
  FILE collision_monitor_coreTargets.cmake DESTINATION ${CM_CORE_CONFIG_DESTINATION})
# A static core leaves qhull and libccd to the program's link: the package config then finds them.
get_target_property(CM_CORE_TYPE collision_monitor_core TYPE)
if(CM_CORE_TYPE STREQUAL "STATIC_LIBRARY")
  set(CM_CORE_STATIC ON)
else()
  set(CM_CORE_STATIC OFF)
endif()
# The package's version is package.xml's (core-only builds have no catkin to read it).
file(READ ${CMAKE_CURRENT_SOURCE_DIR}/package.xml CM_PACKAGE_XML)
if(NOT CM_PACKAGE_XML MATCHES "<version>([0-9]+\\.[0-9]+\\.[0-9]+)</version>")
  message(FATAL_ERROR "collision_monitor: no <version>x.y.z</version> in package.xml")
endif()
set(CM_CORE_VERSION ${CMAKE_MATCH_1})
include(CMakePackageConfigHelpers)
configure_package_config_file(cmake/collision_monitor_coreConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/collision_monitor_coreConfig.cmake
  INSTALL_DESTINATION ${CM_CORE_CONFIG_DESTINATION}
  NO_SET_AND_CHECK_MACRO)
# 0.x: a new minor version may break the API.
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/collision_monitor_coreConfigVersion.cmake
  VERSION ${CM_CORE_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/collision_monitor_coreConfig.cmake
  ${CMAKE_CURRENT_BINARY_DIR}/collision_monitor_coreConfigVersion.cmake
  DESTINATION ${CM_CORE_CONFIG_DESTINATION})

include(cmake/core_tests.cmake)    # exact-answer, shape, dimension and warm-start tests
include(cmake/core_oracle.cmake)   # qhull hull tests, exact-oracle random sweeps, libccd backend
