#pragma once
// Exact validity checks for the guarded start's rounds: tets by exact orient3d, boundary triangle
// pairs by an exact intersection test. The first check covers the whole shell; later ones only
// what touches the vertices moved since (pairs and tets among unmoved vertices were decided
// already), so a round costs little more than its few moved vertices.
// INTERIM: pairs sharing a vertex are not tested yet; the certificate's exact neighbour test
// replaces the pair test when it lands.
#include <gshell/quality/shell_boundary.h>

#include <Eigen/Core>
#include <utility>
#include <vector>

namespace gshell::detail {

struct StartViolations {
  std::vector<int> inverted_tets;                 ///< rows of T, not skipped
  std::vector<std::pair<int, int>> intersections; ///< boundary rows a < b, neither excluded, not both base
};

class StartChecker {
public:
  /// T: tets over the 2n shell vertices; skip / excluded: one flag per tet / boundary row or empty.
  StartChecker(const Eigen::MatrixXi& T, const ShellBoundary& boundary, std::vector<char> skip_tets,
               std::vector<char> excluded_triangles, int num_vertices);

  /// Violations at X (2n x 3). With `moved` (one flag per vertex of X), only tets and pairs with
  /// a moved vertex are tested.
  StartViolations check(const Eigen::MatrixXd& X, const std::vector<char>* moved = nullptr) const;

private:
  Eigen::MatrixXi T_;
  ShellBoundary boundary_;
  std::vector<char> skip_, excluded_;
  int N_;
};

} // namespace gshell::detail
