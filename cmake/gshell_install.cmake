# `cmake --install BUILD [--prefix P]` puts (under P, default CMAKE_INSTALL_PREFIX):
#   bin/gshell                                   the command-line tool
#   lib/libgshell.a                              the library (static, position-independent)
#   include/gshell/...                           the public headers
#   lib/cmake/gshell/gshellConfig*.cmake         the package: find_package(gshell) -> gshell::gshell
#   lib/cmake/gshell/FindGshell*.cmake           find modules for the libraries it links without a CMake package
#   lib/python3.X/.../gshell.cpython-*.so        the Python module (python/CMakeLists.txt)
include(CMakePackageConfigHelpers)
set(GSHELL_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/gshell CACHE STRING
    "Where the CMake package files go (relative to the install prefix)")

install(TARGETS gshell_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(TARGETS gshell EXPORT gshellTargets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/gshell DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(EXPORT gshellTargets NAMESPACE gshell:: DESTINATION ${GSHELL_INSTALL_CMAKEDIR})

configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/gshellConfig.cmake.in
  ${CMAKE_BINARY_DIR}/gshellConfig.cmake INSTALL_DESTINATION ${GSHELL_INSTALL_CMAKEDIR})
# 0.x: a new minor version may change the API.
write_basic_package_version_file(${CMAKE_BINARY_DIR}/gshellConfigVersion.cmake COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_BINARY_DIR}/gshellConfig.cmake ${CMAKE_BINARY_DIR}/gshellConfigVersion.cmake
              ${PROJECT_SOURCE_DIR}/cmake/FindGshellStb.cmake ${PROJECT_SOURCE_DIR}/cmake/FindGshellCHOLMOD.cmake
              ${PROJECT_SOURCE_DIR}/cmake/gshell_find_library.cmake
        DESTINATION ${GSHELL_INSTALL_CMAKEDIR})
