# The installed CMake package: find_package(crosslink) gives the imported executable
# crosslink::crosslink and crosslink_add_check() (cmake/CrosslinkCheck.cmake). The chart scripts
# of the HTML report are installed next to it when report/node_modules exists (npm ci).
include(CMakePackageConfigHelpers)
include(GNUInstallDirs)
include(${CMAKE_CURRENT_LIST_DIR}/CrosslinkCheck.cmake)

set(CROSSLINK_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/crosslink)
install(EXPORT crosslinkTargets NAMESPACE crosslink:: DESTINATION ${CROSSLINK_CMAKE_DIR})
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/crosslinkConfig.cmake.in
  ${PROJECT_BINARY_DIR}/crosslinkConfig.cmake INSTALL_DESTINATION ${CROSSLINK_CMAKE_DIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/crosslinkConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/crosslinkConfig.cmake
              ${PROJECT_BINARY_DIR}/crosslinkConfigVersion.cmake
              ${CMAKE_CURRENT_LIST_DIR}/CrosslinkCheck.cmake
        DESTINATION ${CROSSLINK_CMAKE_DIR})
# Found at run time by `crosslink compare --report` as <prefix>/share/crosslink/report.
foreach(_script vega/build/vega.min.js vega-lite/build/vega-lite.min.js
                vega-embed/build/vega-embed.min.js)
  install(FILES ${PROJECT_SOURCE_DIR}/report/node_modules/${_script}
          DESTINATION ${CMAKE_INSTALL_DATADIR}/crosslink/report OPTIONAL)
endforeach()
# The bundled definitions, as <prefix>/share/crosslink/mechanisms: `crosslink compare` without a
# FILE runs the sewing machine from there when the current directory has no mechanisms/.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/mechanisms/ DESTINATION ${CMAKE_INSTALL_DATADIR}/crosslink/mechanisms
        FILES_MATCHING PATTERN "*.toml")
