# OSMesa (Mesa's off-screen software OpenGL), for headless rendering (Debian: libosmesa6-dev):
# GshellDeps::OSMesa. Used by gshell's build for the headers; the library is loaded at run time.
include(${CMAKE_CURRENT_LIST_DIR}/gshell_find_library.cmake)
gshell_find_library(PACKAGE GshellOSMesa TARGET GshellDeps::OSMesa HEADER GL/osmesa.h LIBRARIES OSMesa)
