# Precompiled headers: the standard library, Eigen, OpenCV's core and
# nlohmann/json (and GoogleTest for the tests) are parsed once per build, not
# once per translation unit. A file's own #include lines stay what it uses; the
# precompiled set only comes first. GCC takes a precompiled header only where
# -fPIC matches (other flags, -D macros the headers do not read, and -O3 on a
# file leave it valid), so there are three of them:
#   hdabench_pch_library  the modules (position-independent code)
#   hdabench_pch_program  the hdabench program and the benchmarks
#   hdabench_pch_test     the test programs (also GoogleTest)
# Each is an object library of one empty file whose headers the others reuse.
# Measured from nothing on 2 cores: the normal build 591 s without them, 556 s
# with; the outputs are the same bytes (most of a file's time is its own code,
# not the headers it parses). The clang tree of the sanitizers and the fuzz
# harnesses (tools/sanitize-tree.sh) uses them too. A folder configured with
# HDABENCH_PCH=OFF and without CMAKE_UNITY_BUILD compiles each file on its own
# #include lines.
#
# clang writes the time stamps of the headers into a precompiled header, so
# the one a new clone makes differs from the last, and ccache finds nothing
# compiled with it (ccache's manual, "Precompiled headers"). Without them it
# is the same bytes each time; the build still remakes it when a header
# changes.
if(HDABENCH_PCH AND CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
  add_compile_options("SHELL:-Xclang -fno-pch-timestamp")
endif()

set(HDABENCH_PCH_HEADERS
  <algorithm> <array> <cmath> <cstdint> <filesystem> <fstream> <functional> <limits> <map> <memory>
  <optional> <sstream> <string> <utility> <vector>
  <Eigen/Core> <Eigen/Geometry> <opencv2/core.hpp> <opencv2/imgproc.hpp> <nlohmann/json.hpp>)

# hdabench_add_precompiled_headers(<owner> [POSITION_INDEPENDENT] [HEADERS ...] [LIBS ...]):
# the owner of one precompiled set: HDABENCH_PCH_HEADERS and HEADERS, found
# through LIBS, compiled with the project's warnings and flags.
function(hdabench_add_precompiled_headers owner)
  if(NOT HDABENCH_PCH)
    return()
  endif()
  cmake_parse_arguments(ARG "POSITION_INDEPENDENT" "" "HEADERS;LIBS" ${ARGN})
  add_library(${owner} OBJECT ${PROJECT_SOURCE_DIR}/cmake/precompiled_headers.cc)
  target_link_libraries(${owner} PRIVATE Eigen3::Eigen opencv_core opencv_imgproc nlohmann_json::nlohmann_json
                        ${ARG_LIBS})
  set_target_properties(${owner} PROPERTIES POSITION_INDEPENDENT_CODE ${ARG_POSITION_INDEPENDENT})
  hdabench_set_warnings(${owner})
  # C++ headers only: the bench has no C files.
  target_precompile_headers(${owner} PRIVATE ${HDABENCH_PCH_HEADERS} ${ARG_HEADERS})
endfunction()

# hdabench_use_precompiled_headers(<target> <owner>): <target>'s C++ files
# start with <owner>'s precompiled set. The owner's -fPIC must be <target>'s.
function(hdabench_use_precompiled_headers target owner)
  if(HDABENCH_PCH)
    target_precompile_headers(${target} REUSE_FROM ${owner})
  endif()
endfunction()
