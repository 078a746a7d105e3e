#include <gshell/solver/polar_decomposition.h>

#include "solver/polar_3x3.h"

namespace gshell {

Eigen::Matrix3d closest_rotation(const Eigen::Matrix3d& F) { return detail::closest_rotation_inline(F); }

} // namespace gshell
