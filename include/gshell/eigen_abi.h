#pragma once
// gshell's functions take and return Eigen objects, so the library and the code calling it must
// agree on Eigen's memory layout: fixed-size members aligned to at most 16 bytes, and heap blocks
// from Eigen's own aligned allocator. The CMake target gshell::gshell sets the three macros
// below; code compiled without them (another build system, a second target that does not link
// gshell::gshell) freed the library's blocks with plain free ("double free or corruption") or
// read its structs at other offsets. This stops such a build instead.
#include <Eigen/Core>

#if EIGEN_MAX_ALIGN_BYTES != 16 || EIGEN_MAX_STATIC_ALIGN_BYTES != 16 || EIGEN_MALLOC_ALREADY_ALIGNED != 0
#error "gshell: compile with -DEIGEN_MAX_ALIGN_BYTES=16 -DEIGEN_MAX_STATIC_ALIGN_BYTES=16 -DEIGEN_MALLOC_ALREADY_ALIGNED=0 (the CMake target gshell::gshell sets them), so that Eigen objects passed to and from gshell share one layout"
#endif
