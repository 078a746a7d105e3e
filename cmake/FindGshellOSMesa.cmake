# OSMesa (Mesa's off-screen software OpenGL), for headless rendering. Debian: libosmesa6-dev.
# Defines GshellDeps::OSMesa. Used by gshell's build and by the installed gshellConfig.cmake.
find_path(GshellOSMesa_INCLUDE_DIR GL/osmesa.h)
find_library(GshellOSMesa_LIBRARY OSMesa)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(GshellOSMesa REQUIRED_VARS GshellOSMesa_LIBRARY GshellOSMesa_INCLUDE_DIR)
mark_as_advanced(GshellOSMesa_INCLUDE_DIR GshellOSMesa_LIBRARY)
if(GshellOSMesa_FOUND AND NOT TARGET GshellDeps::OSMesa)
  add_library(GshellDeps::OSMesa UNKNOWN IMPORTED)
  set_target_properties(GshellDeps::OSMesa PROPERTIES
    IMPORTED_LOCATION "${GshellOSMesa_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${GshellOSMesa_INCLUDE_DIR}")
endif()
