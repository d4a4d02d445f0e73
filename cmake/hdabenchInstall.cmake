# install() rules and the exported package: another project can
#   find_package(hdabench 0.1 REQUIRED)
#   target_link_libraries(app PRIVATE hdabench::calib hdabench::datasets)
include(CMakePackageConfigHelpers)
get_property(module_targets GLOBAL PROPERTY HDABENCH_MODULE_TARGETS)
install(TARGETS ${module_targets} EXPORT hdabenchTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
set(config_dir ${CMAKE_INSTALL_LIBDIR}/cmake/hdabench)
install(EXPORT hdabenchTargets NAMESPACE hdabench:: DESTINATION ${config_dir})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/hdabenchConfig.cmake.in
  ${PROJECT_BINARY_DIR}/hdabenchConfig.cmake INSTALL_DESTINATION ${config_dir})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/hdabenchConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/hdabenchConfig.cmake
              ${PROJECT_BINARY_DIR}/hdabenchConfigVersion.cmake
              ${PROJECT_SOURCE_DIR}/cmake/FindMrcal.cmake
              ${PROJECT_SOURCE_DIR}/cmake/FindMrgingham.cmake
        DESTINATION ${config_dir})
