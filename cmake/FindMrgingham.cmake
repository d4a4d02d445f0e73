# Finds libmrgingham (Debian: libmrgingham-dev), the chessboard corner finder mrcal
# uses, which ships neither a CMake config nor a pkg-config file. Defines the
# imported target mrgingham::mrgingham. It finds square N x N chessboards only.
find_path(Mrgingham_INCLUDE_DIR NAMES mrgingham/mrgingham.hh)
find_library(Mrgingham_LIBRARY NAMES mrgingham)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(Mrgingham REQUIRED_VARS Mrgingham_LIBRARY Mrgingham_INCLUDE_DIR)
if(Mrgingham_FOUND AND NOT TARGET mrgingham::mrgingham)
  add_library(mrgingham::mrgingham UNKNOWN IMPORTED)
  set_target_properties(mrgingham::mrgingham PROPERTIES
    IMPORTED_LOCATION "${Mrgingham_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${Mrgingham_INCLUDE_DIR}")
endif()
mark_as_advanced(Mrgingham_INCLUDE_DIR Mrgingham_LIBRARY)
