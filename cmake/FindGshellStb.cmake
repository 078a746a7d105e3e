# The stb single-file libraries as Debian builds them (libstb-dev: headers in include/stb, the
# implementations compiled into libstb): PNG encoding and decoding, TrueType glyphs.
# Defines GshellDeps::stb. Used by gshell's build and by the installed gshellConfig.cmake.
find_path(GshellStb_INCLUDE_DIR stb_image_write.h PATH_SUFFIXES stb)
find_library(GshellStb_LIBRARY stb)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(GshellStb REQUIRED_VARS GshellStb_LIBRARY GshellStb_INCLUDE_DIR)
mark_as_advanced(GshellStb_INCLUDE_DIR GshellStb_LIBRARY)
if(GshellStb_FOUND AND NOT TARGET GshellDeps::stb)
  add_library(GshellDeps::stb UNKNOWN IMPORTED)
  set_target_properties(GshellDeps::stb PROPERTIES
    IMPORTED_LOCATION "${GshellStb_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${GshellStb_INCLUDE_DIR}")
endif()
