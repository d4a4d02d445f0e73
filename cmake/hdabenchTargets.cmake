# Helpers shared by every module's CMakeLists.txt.

# hdabench_set_warnings(<target>): the project's warning set, per target.
function(hdabench_set_warnings target)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast
    -Wcast-align -Woverloaded-virtual -Wconversion -Wno-sign-conversion
    -Wdouble-promotion -Wformat=2 -Wimplicit-fallthrough)
  if(HDABENCH_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

# hdabench_add_module(<name> SOURCES ... PUBLIC_LIBS ... PRIVATE_LIBS ... HEADERS ...)
# Declares library target hdabench_<name>, exported as hdabench::<name>. Headers
# are included as "<name>/<file>.h" both from the source tree and once installed.
function(hdabench_add_module name)
  cmake_parse_arguments(ARG "" "" "SOURCES;HEADERS;PUBLIC_LIBS;PRIVATE_LIBS" ${ARGN})
  set(target hdabench_${name})
  add_library(${target} ${ARG_SOURCES})
  add_library(hdabench::${name} ALIAS ${target})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${name} OUTPUT_NAME hdabench_${name}
                                             POSITION_INDEPENDENT_CODE ON)
  target_compile_features(${target} PUBLIC cxx_std_17)
  target_include_directories(${target} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}/hdabench>)
  target_link_libraries(${target} PUBLIC ${ARG_PUBLIC_LIBS} PRIVATE ${ARG_PRIVATE_LIBS})
  hdabench_set_warnings(${target})
  if(HDABENCH_SANITIZE)
    # Code built with the sanitizers needs their runtime wherever it is linked,
    # including in projects that use the installed package.
    target_link_options(${target} INTERFACE -fsanitize=address,undefined)
  endif()
  install(FILES ${ARG_HEADERS} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/hdabench/${name})
  set_property(GLOBAL APPEND PROPERTY HDABENCH_MODULE_TARGETS ${target})
endfunction()
