# Added to a consumer's build by find_package(catkin COMPONENTS collision_monitor): the installed
# headers use C++17 (std::variant, std::optional, if constexpr).
if(NOT CMAKE_CXX_STANDARD OR CMAKE_CXX_STANDARD MATCHES "^(98|11|14)$")
  set(CMAKE_CXX_STANDARD 17)
  set(CMAKE_CXX_STANDARD_REQUIRED ON)
endif()
