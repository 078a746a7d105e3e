#pragma once
#include <gshell/eigen_abi.h>
#include <Eigen/Core>

namespace gshell {

/// Area-weighted unit vertex normals (n x 3). Isolated vertices get a zero normal.
/// \throws InputError when V is not n x 3 or F not m x 3 with ids in [0, n) (also offset_top).
Eigen::MatrixXd vertex_normals(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);

/// The offset top surface: V + eta * vertex_normals (the paper's baseline, the solver's start).
/// \throws InputError also when eta is not finite.
Eigen::MatrixXd offset_top(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double eta);

} // namespace gshell
