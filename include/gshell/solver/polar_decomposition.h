#pragma once
#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <cstddef>

namespace gshell {

/// Rotation part of the polar decomposition of a 3x3 matrix: the rotation R (det R = +1) closest
/// to F in the Frobenius norm, R = U diag(1, 1, det(U V^T)) V^T. Correct for inverted F
/// (det F < 0) and for rank-deficient F. Fast enough for the local step of every iteration.
/// When R is not unique (sigma_2 + sigma_3 = 0 with the sign of det F on sigma_3, e.g. rank <= 1),
/// one of the closest rotations is returned.
Eigen::Matrix3d closest_rotation(const Eigen::Matrix3d& F);

/// closest_rotation of `count` matrices (the same results), several at a time in SIMD lanes:
/// the throughput the solver's local step gets. Single-threaded; R may not alias F.
void closest_rotations(const Eigen::Matrix3d* F, Eigen::Matrix3d* R, std::size_t count);

} // namespace gshell
