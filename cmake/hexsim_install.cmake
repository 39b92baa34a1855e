# `cmake --install BUILD --prefix P`: the libraries and public headers (installed by hexsim_library),
# the hexsim binary, worlds/ into P/share/hexsim (common/src/paths.cc looks in ../share/hexsim beside
# the executable; other programs set HEXSIM_DATA_DIR), and a package so that find_package(hexsim)
# gives hexsim::common, hexsim::sim, ... with their dependencies.
include(CMakePackageConfigHelpers)

if(TARGET hexsim)
  install(TARGETS hexsim RUNTIME DESTINATION bin)
endif()
install(DIRECTORY ${HEXSIM_SOURCE_DIR}/worlds/ DESTINATION share/hexsim/worlds)

install(EXPORT hexsimTargets NAMESPACE hexsim:: DESTINATION lib/cmake/hexsim)
configure_package_config_file(${HEXSIM_SOURCE_DIR}/cmake/hexsimConfig.cmake.in
  ${CMAKE_BINARY_DIR}/hexsimConfig.cmake INSTALL_DESTINATION lib/cmake/hexsim)
write_basic_package_version_file(${CMAKE_BINARY_DIR}/hexsimConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_BINARY_DIR}/hexsimConfig.cmake ${CMAKE_BINARY_DIR}/hexsimConfigVersion.cmake
  DESTINATION lib/cmake/hexsim)

# The examples, built by CTest against the installed package (examples/CMakeLists.txt).
if(HEXSIM_BUILD_TESTS AND EXISTS ${HEXSIM_SOURCE_DIR}/examples/CMakeLists.txt)
  add_subdirectory(${HEXSIM_SOURCE_DIR}/examples ${CMAKE_BINARY_DIR}/examples)
endif()
