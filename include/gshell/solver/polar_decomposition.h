#pragma once
#include <Eigen/Core>

namespace gshell {

/// Rotation part of the polar decomposition of a 3x3 matrix: the rotation R (det R = +1) closest
/// to F in the Frobenius norm, R = U diag(1, 1, det(U V^T)) V^T. Correct for inverted F
/// (det F < 0) and for rank-deficient F. Fast enough for the local step of every iteration.
Eigen::Matrix3d closest_rotation(const Eigen::Matrix3d& F);

} // namespace gshell
