#pragma once
// Per-tet stretch ||F - R(F)||_F^2 = sum_i (sigma_i - 1)^2 (docs/design.md "The energy",
// "Quality measures").
#include <gshell/solver/rest_tets.h>
#include <gshell/eigen_abi.h>
#include <Eigen/Core>

namespace gshell {

/// Stretch of every tet of `rest` at positions X.
/// \throws InputError when X is not N x 3 or a tet refers to a row outside it.
Eigen::VectorXd tet_stretch(const RestTets& rest, const Eigen::MatrixXd& X);

/// det F of every tet (<= 0 means inverted).
/// \throws InputError when X is not N x 3 or a tet refers to a row outside it.
Eigen::VectorXd tet_deformation_determinants(const RestTets& rest, const Eigen::MatrixXd& X);

struct StretchStats {
  double mean = 0, volume_mean = 0, max = 0, p99 = 0; ///< volume_mean weights by rest volume
  int inverted = 0;                                    ///< tets with det F <= 0
};

/// Mean, volume-weighted mean, max and 99th percentile (nearest rank) of the stretch of `rest` at
/// X, and the count of tets with det F <= 0.
/// \throws InputError when X is not N x 3 or a tet refers to a row outside it.
StretchStats stretch_stats(const RestTets& rest, const Eigen::MatrixXd& X);

/// The same statistics from per-tet stretch, det F and rest volume already computed.
/// \throws InputError when the three vectors differ in length.
StretchStats stretch_stats(const Eigen::VectorXd& stretch, const Eigen::VectorXd& determinants,
                           const Eigen::VectorXd& volume);

} // namespace gshell
