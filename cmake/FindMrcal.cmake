# Finds libmrcal (Debian: libmrcal-dev), which ships neither a CMake config nor a
# pkg-config file. Defines the imported target mrcal::mrcal.
# Note: mrcal's headers have no extern "C" guards; include them inside extern "C" { }.
find_path(Mrcal_INCLUDE_DIR NAMES mrcal/mrcal.h)
find_library(Mrcal_LIBRARY NAMES mrcal)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(Mrcal REQUIRED_VARS Mrcal_LIBRARY Mrcal_INCLUDE_DIR)
if(Mrcal_FOUND AND NOT TARGET mrcal::mrcal)
  add_library(mrcal::mrcal UNKNOWN IMPORTED)
  set_target_properties(mrcal::mrcal PROPERTIES
    IMPORTED_LOCATION "${Mrcal_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${Mrcal_INCLUDE_DIR}")
endif()
mark_as_advanced(Mrcal_INCLUDE_DIR Mrcal_LIBRARY)
