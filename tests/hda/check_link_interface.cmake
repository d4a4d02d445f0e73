# Fails when the flight module (or the calib module it uses) links a library
# that hda/ must not depend on.
file(READ "${LINK_FILE}" libs)
foreach(forbidden IN ITEMS opengv Ceres ceres colmap reference datasets)
  string(FIND "${libs}" "${forbidden}" found)
  if(NOT found EQUAL -1)
    message(FATAL_ERROR "hda links '${forbidden}': ${libs}")
  endif()
endforeach()
message(STATUS "hda link interface: ${libs}")
