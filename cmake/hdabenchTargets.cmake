# Helpers shared by every module's CMakeLists.txt.

# hdabench_set_warnings(<target>): the project's warning set, per target.
# -Wdouble-promotion is GCC's: it flags float arithmetic promoted to double.
# clang's flags every float widened to double, including initialisations and
# the double{x} the code writes to widen on purpose (68 places), so a
# clang build (the fuzzing build) leaves it out; every GCC build keeps it.
function(hdabench_set_warnings target)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast
    -Wcast-align -Woverloaded-virtual -Wconversion -Wno-sign-conversion
    $<$<NOT:$<CXX_COMPILER_ID:Clang>>:-Wdouble-promotion> -Wformat=2 -Wimplicit-fallthrough)
  if(HDABENCH_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

# hdabench_add_module(<name> [INTERFACE] USES ... SOURCES ... [FUZZED ...] [HOT ...] HEADERS ... PUBLIC_LIBS ... PRIVATE_LIBS ...)
# Declares library target hdabench_<name>, exported as hdabench::<name>, for
# the folder of the calling CMakeLists.txt. Headers are included by their path
# from the top of the tree ("reference/colmap/colmap_runner.h"), both from the
# source tree and once installed. USES names the bench modules this one may
# include and link (docs/architecture.md); each must have been declared before
# it, so modules form layers. The test module_rules checks every module's
# links and every #include of its folder against USES.
# FUZZED names the sources that read outside input (files, other programs'
# output), which the libFuzzer harnesses reach (tests/fuzz): in the fuzzing
# tree (HDABENCH_FUZZ) they alone carry libFuzzer's coverage counters, which
# guide the fuzzer and slow the code they are in ten- to twentyfold. The
# numeric code runs under the sanitizers without them. HOT names the
# sources whose inner loops the unit tests spend minutes in (the renderers):
# in a sanitizer tree (HDABENCH_SANITIZE, at -O1 for its compile time) they
# compile at -O2, which inlines Eigen's small expressions that -O1 calls out
# of line; every check of the sanitizers stays. A source with its own
# compile options is compiled on its own, outside the unity batches.
function(hdabench_add_module name)
  cmake_parse_arguments(ARG "INTERFACE" "" "SOURCES;FUZZED;HOT;HEADERS;USES;PUBLIC_LIBS;PRIVATE_LIBS" ${ARGN})
  set(target hdabench_${name})
  file(RELATIVE_PATH folder ${PROJECT_SOURCE_DIR} ${CMAKE_CURRENT_SOURCE_DIR})
  if(ARG_INTERFACE)
    add_library(${target} INTERFACE)
    set(scope INTERFACE)
    set(links_property INTERFACE_LINK_LIBRARIES)
  else()
    add_library(${target} ${ARG_SOURCES})
    set(scope PUBLIC)
    set(links_property LINK_LIBRARIES)
    set_target_properties(${target} PROPERTIES OUTPUT_NAME hdabench_${name}
                                               POSITION_INDEPENDENT_CODE ON)
    target_link_libraries(${target} PUBLIC ${ARG_PUBLIC_LIBS} PRIVATE ${ARG_PRIVATE_LIBS})
    hdabench_set_warnings(${target})
    hdabench_use_precompiled_headers(${target} hdabench_pch_library)
    if(HDABENCH_FUZZ AND ARG_FUZZED)
      # clang refuses a precompiled header made without the counters.
      set_source_files_properties(${ARG_FUZZED} PROPERTIES COMPILE_OPTIONS -fsanitize=fuzzer-no-link
                                                           SKIP_PRECOMPILE_HEADERS ON)
    endif()
    if(HDABENCH_SANITIZE AND ARG_HOT)
      set_property(SOURCE ${ARG_HOT} APPEND PROPERTY COMPILE_OPTIONS -O2)
    endif()
  endif()
  add_library(hdabench::${name} ALIAS ${target})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${name})
  target_compile_features(${target} ${scope} cxx_std_17)
  target_include_directories(${target} ${scope}
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}/hdabench>)
  if(ARG_INTERFACE)
    target_link_libraries(${target} INTERFACE ${ARG_PUBLIC_LIBS})
  endif()
  if(HDABENCH_SANITIZE AND NOT ARG_INTERFACE)
    # Code built with the sanitizers needs their runtime wherever it is linked,
    # including in projects that use the installed package.
    target_link_options(${target} INTERFACE -fsanitize=address,undefined)
  endif()
  install(FILES ${ARG_HEADERS} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/hdabench/${folder})
  hdabench_register_module(${name} ${folder} "${ARG_USES}" ${target} ${links_property})
  set_property(GLOBAL APPEND PROPERTY HDABENCH_MODULE_TARGETS ${target})
endfunction()

# hdabench_register_module(<name> <folder> <uses> <target> <links property>):
# records a module for the module_rules test, refusing a USES entry that names
# a module not declared before this one (a layer above it, or itself).
function(hdabench_register_module name folder uses target links_property)
  get_property(declared GLOBAL PROPERTY HDABENCH_MODULE_NAMES)
  foreach(used IN LISTS uses)
    if(NOT used IN_LIST declared)
      message(FATAL_ERROR "module ${name} (${folder}) uses '${used}', which is not a module "
                          "declared before it: modules may use only lower layers")
    endif()
  endforeach()
  set_property(GLOBAL APPEND PROPERTY HDABENCH_MODULE_NAMES ${name})
  string(REPLACE ";" "," uses_text "${uses}")
  set_property(GLOBAL APPEND PROPERTY HDABENCH_MODULE_RULES
    "${name}|${folder}|${uses_text}|$<JOIN:$<TARGET_PROPERTY:${target},${links_property}>,,>")
endfunction()

# hdabench_write_module_rules(): the modules, their folders, what each may use
# and what each links, for tests/architecture/check_module_rules.cmake.
function(hdabench_write_module_rules)
  get_property(rules GLOBAL PROPERTY HDABENCH_MODULE_RULES)
  string(REPLACE ";" "\n" content "${rules}")
  file(GENERATE OUTPUT ${PROJECT_BINARY_DIR}/module_rules.txt CONTENT "${content}\n")
endfunction()

# hdabench_embed_python(SCRIPT FUNCTION HEADER NAMESPACE): compiles a Python
# script into the bench as `const std::string& NAMESPACE::FUNCTION()`, declared
# in HEADER. Reads SCRIPT (in the current source folder), refuses a script
# holding the raw-string end ')hdabench_py"', writes <SCRIPT's stem>_script.cc
# into the current binary folder from cmake/embedded_python_script.cc.in, and
# reconfigures when the script changes.
function(hdabench_embed_python script function header namespace)
  file(READ ${CMAKE_CURRENT_SOURCE_DIR}/${script} HDABENCH_SCRIPT_TEXT)
  file(RELATIVE_PATH HDABENCH_SCRIPT_PATH ${PROJECT_SOURCE_DIR} ${CMAKE_CURRENT_SOURCE_DIR}/${script})
  string(FIND "${HDABENCH_SCRIPT_TEXT}" ")hdabench_py\"" delimiter_at)
  if(NOT delimiter_at EQUAL -1)
    message(FATAL_ERROR "${HDABENCH_SCRIPT_PATH} holds the raw-string end ')hdabench_py\"'")
  endif()
  set(HDABENCH_SCRIPT_FUNCTION ${function})
  set(HDABENCH_SCRIPT_HEADER ${header})
  set(HDABENCH_SCRIPT_NAMESPACE ${namespace})
  get_filename_component(stem ${script} NAME_WE)
  configure_file(${PROJECT_SOURCE_DIR}/cmake/embedded_python_script.cc.in
                 ${CMAKE_CURRENT_BINARY_DIR}/${stem}_script.cc @ONLY)
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${script})
endfunction()
