# OSMesa (Mesa's off-screen software OpenGL), for headless rendering (Debian: libosmesa6-dev):
# GshellDeps::OSMesa. Used by gshell's build and by the installed gshellConfig.cmake.
include(${CMAKE_CURRENT_LIST_DIR}/gshell_find_library.cmake)
gshell_find_library(PACKAGE GshellOSMesa TARGET GshellDeps::OSMesa HEADER GL/osmesa.h LIBRARIES OSMesa)
