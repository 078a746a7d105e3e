#pragma once
// Per-tet stretch ||F - R(F)||_F^2 = sum_i (sigma_i - 1)^2 (docs/design.md "The energy",
// "Quality measures").
#include <gshell/solver/rest_tets.h>
#include <Eigen/Core>

namespace gshell {

/// Stretch of every tet of `rest` at positions X.
Eigen::VectorXd tet_stretch(const RestTets& rest, const Eigen::MatrixXd& X);

/// det F of every tet (<= 0 means inverted).
Eigen::VectorXd tet_deformation_determinants(const RestTets& rest, const Eigen::MatrixXd& X);

struct StretchStats {
  double mean = 0, volume_mean = 0, max = 0, p99 = 0; ///< volume_mean weights by rest volume
  int inverted = 0;                                    ///< tets with det F <= 0
};

StretchStats stretch_stats(const RestTets& rest, const Eigen::MatrixXd& X);

/// The same statistics from per-tet stretch, det F and rest volume already computed.
StretchStats stretch_stats(const Eigen::VectorXd& stretch, const Eigen::VectorXd& determinants,
                           const Eigen::VectorXd& volume);

} // namespace gshell
