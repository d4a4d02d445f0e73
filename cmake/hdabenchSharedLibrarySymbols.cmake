# hdabench_require_symbols(LIBRARY_FILE WHAT SYMBOL...): stops the configuration
# with an error naming LIBRARY_FILE (WHAT says which library it is) and every
# SYMBOL its dynamic symbol table does not define. For code that takes functions
# from a shared library with dlsym (tools/util/shared_library.h) by their mangled
# names: a library whose functions changed fails here, when building, not on
# the first command that needs it.
function(hdabench_require_symbols library_file what)
  find_program(HDABENCH_READELF NAMES readelf)
  mark_as_advanced(HDABENCH_READELF)
  if(NOT HDABENCH_READELF)
    message(FATAL_ERROR "readelf (Debian package binutils) not found: it checks the functions the bench "
                        "takes from ${what} (${library_file})")
  endif()
  execute_process(COMMAND ${HDABENCH_READELF} -W --dyn-syms "${library_file}"
                  OUTPUT_VARIABLE table ERROR_VARIABLE error RESULT_VARIABLE status)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "cannot read the symbols of ${what} (${library_file}): ${error}")
  endif()
  set(missing "")
  foreach(symbol IN LISTS ARGN)
    # A defined symbol has a section number in the Ndx column (UND: undefined);
    # a versioned one is followed by @ and its version.
    if(NOT table MATCHES "[ \t][0-9]+ ${symbol}(@[^\n]*)?\n")
      list(APPEND missing "${symbol}")
    endif()
  endforeach()
  if(missing)
    list(JOIN missing "\n  " missing_lines)
    message(FATAL_ERROR "${what} (${library_file}) does not define the functions the bench takes from it "
                        "by name:\n  ${missing_lines}\nIts version or ABI is not the one the bench was written for.")
  endif()
endfunction()
