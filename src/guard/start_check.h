#pragma once
// INTERIM exact validity check for the guarded start, until the certificate (certify_shell) lands:
// inverted tets by exact orient3d, intersecting boundary triangle pairs by the exact pair test
// (pairs sharing a vertex are not tested yet).
#include <gshell/quality/shell_boundary.h>

#include <Eigen/Core>
#include <utility>
#include <vector>

namespace gshell::detail {

struct StartViolations {
  std::vector<int> inverted_tets;                  ///< rows of T
  std::vector<std::pair<int, int>> intersections;  ///< rows of the boundary, base/base pairs left out
};

/// X: 2n x 3 shell vertices.
StartViolations start_violations(const Eigen::MatrixXd& X, const Eigen::MatrixXi& T, const ShellBoundary& boundary);

} // namespace gshell::detail
