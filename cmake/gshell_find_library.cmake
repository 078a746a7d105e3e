# gshell_find_library(PACKAGE <name> TARGET <target> HEADER <file> LIBRARIES <lib>... [PATH_SUFFIXES <dir>...])
# The body of gshell's find modules for libraries that ship no CMake package: finds the header
# and the libraries, reports like any find module (<name>_FOUND, found/not found message) and
# defines the imported target <target> (the first library, the others linked through it, the
# header's folder as include directory). <name>_LIBRARIES lists the libraries found.
function(gshell_find_library)
  cmake_parse_arguments(ARG "" "PACKAGE;TARGET;HEADER" "LIBRARIES;PATH_SUFFIXES" ${ARGN})
  set(required "")
  set(libraries "")
  foreach(name ${ARG_LIBRARIES})
    find_library(${ARG_PACKAGE}_${name}_LIBRARY ${name})
    list(APPEND required ${ARG_PACKAGE}_${name}_LIBRARY)
    list(APPEND libraries ${${ARG_PACKAGE}_${name}_LIBRARY})
  endforeach()
  find_path(${ARG_PACKAGE}_INCLUDE_DIR ${ARG_HEADER} PATH_SUFFIXES ${ARG_PATH_SUFFIXES})
  list(APPEND required ${ARG_PACKAGE}_INCLUDE_DIR)
  mark_as_advanced(${required})
  include(FindPackageHandleStandardArgs)
  find_package_handle_standard_args(${ARG_PACKAGE} REQUIRED_VARS ${required})
  set(${ARG_PACKAGE}_FOUND ${${ARG_PACKAGE}_FOUND} PARENT_SCOPE)
  set(${ARG_PACKAGE}_LIBRARIES ${libraries} PARENT_SCOPE)
  if(${ARG_PACKAGE}_FOUND AND NOT TARGET ${ARG_TARGET})
    list(POP_FRONT libraries first)
    add_library(${ARG_TARGET} UNKNOWN IMPORTED)
    set_target_properties(${ARG_TARGET} PROPERTIES
      IMPORTED_LOCATION "${first}"
      INTERFACE_INCLUDE_DIRECTORIES "${${ARG_PACKAGE}_INCLUDE_DIR}"
      INTERFACE_LINK_LIBRARIES "${libraries}")
  endif()
endfunction()
