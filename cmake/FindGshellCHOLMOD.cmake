# CHOLMOD (SuiteSparse's sparse Cholesky), which Debian ships without a CMake package.
# Defines GshellDeps::CHOLMOD (libcholmod + libsuitesparseconfig, and cholmod.h's folder).
# Used by gshell's build and, for the link step of its static library, by the installed
# gshellConfig.cmake; the Gshell prefix keeps it clear of other projects' FindCHOLMOD modules.
find_path(GshellCHOLMOD_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse)
find_library(GshellCHOLMOD_LIBRARY cholmod)
find_library(GshellCHOLMOD_CONFIG_LIBRARY suitesparseconfig)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(GshellCHOLMOD
  REQUIRED_VARS GshellCHOLMOD_LIBRARY GshellCHOLMOD_CONFIG_LIBRARY GshellCHOLMOD_INCLUDE_DIR)
mark_as_advanced(GshellCHOLMOD_INCLUDE_DIR GshellCHOLMOD_LIBRARY GshellCHOLMOD_CONFIG_LIBRARY)
if(GshellCHOLMOD_FOUND AND NOT TARGET GshellDeps::CHOLMOD)
  add_library(GshellDeps::CHOLMOD UNKNOWN IMPORTED)
  set_target_properties(GshellDeps::CHOLMOD PROPERTIES
    IMPORTED_LOCATION "${GshellCHOLMOD_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${GshellCHOLMOD_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${GshellCHOLMOD_CONFIG_LIBRARY}")
endif()
