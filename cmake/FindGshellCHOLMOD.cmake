# CHOLMOD (SuiteSparse's sparse Cholesky), which Debian ships without a CMake package:
# GshellDeps::CHOLMOD (libcholmod + libsuitesparseconfig, and cholmod.h's folder). Used by gshell's
# build and, for the link step of its static library, by the installed gshellConfig.cmake; the
# Gshell prefix keeps it clear of other projects' FindCHOLMOD modules.
include(${CMAKE_CURRENT_LIST_DIR}/gshell_find_library.cmake)
gshell_find_library(PACKAGE GshellCHOLMOD TARGET GshellDeps::CHOLMOD HEADER cholmod.h
                    LIBRARIES cholmod suitesparseconfig PATH_SUFFIXES suitesparse)
