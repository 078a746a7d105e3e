# The stb single-file libraries as Debian builds them (libstb-dev: headers in include/stb, the
# implementations compiled into libstb): PNG encoding and decoding, TrueType glyphs.
# GshellDeps::stb. Used by gshell's build and by the installed gshellConfig.cmake.
include(${CMAKE_CURRENT_LIST_DIR}/gshell_find_library.cmake)
gshell_find_library(PACKAGE GshellStb TARGET GshellDeps::stb HEADER stb_image_write.h LIBRARIES stb PATH_SUFFIXES stb)
