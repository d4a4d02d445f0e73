# Finds libmrgingham (Debian: libmrgingham-dev), the chessboard corner finder mrcal
# uses, which ships neither a CMake config nor a pkg-config file. Defines the
# imported target mrgingham::mrgingham, the target mrgingham::headers (its
# headers alone, for code that loads the library when it first needs it) and
# Mrgingham_SONAME. It finds square N x N chessboards only.
find_path(Mrgingham_INCLUDE_DIR NAMES mrgingham/mrgingham.hh)
find_library(Mrgingham_LIBRARY NAMES mrgingham)
if(Mrgingham_LIBRARY AND NOT Mrgingham_SONAME)
  find_program(Mrgingham_READELF NAMES readelf)
  mark_as_advanced(Mrgingham_READELF)
  if(Mrgingham_READELF)
    execute_process(COMMAND ${Mrgingham_READELF} -d "${Mrgingham_LIBRARY}"
                    OUTPUT_VARIABLE mrgingham_dynamic_section ERROR_QUIET)
    if(mrgingham_dynamic_section MATCHES "Library soname: \\[([^]]+)\\]")
      set(Mrgingham_SONAME "${CMAKE_MATCH_1}" CACHE STRING "The soname of libmrgingham")
    endif()
  endif()
endif()
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(Mrgingham REQUIRED_VARS Mrgingham_LIBRARY Mrgingham_INCLUDE_DIR Mrgingham_SONAME)
if(Mrgingham_FOUND AND NOT TARGET mrgingham::mrgingham)
  add_library(mrgingham::mrgingham UNKNOWN IMPORTED)
  set_target_properties(mrgingham::mrgingham PROPERTIES
    IMPORTED_LOCATION "${Mrgingham_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${Mrgingham_INCLUDE_DIR}")
  add_library(mrgingham::headers INTERFACE IMPORTED)
  set_target_properties(mrgingham::headers PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${Mrgingham_INCLUDE_DIR}")
endif()
mark_as_advanced(Mrgingham_INCLUDE_DIR Mrgingham_LIBRARY)
