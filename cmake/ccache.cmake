# ccache as the compiler launcher where it is installed (the main build and fuzz/'s). scripts/env.sh
# sets its base folder (the package) and leaves the working folder out of its hash, so that a
# clone elsewhere finds the objects an earlier one built.
find_program(CCACHE_PROGRAM ccache)
if(CCACHE_PROGRAM AND NOT CMAKE_CXX_COMPILER_LAUNCHER)
  set(CMAKE_CXX_COMPILER_LAUNCHER "${CCACHE_PROGRAM}")
endif()
