#pragma once
// A valid start for the guarded solver: the top vertex i at b_i + t_i d_i along its extrusion
// direction, with per-vertex thicknesses t_i as large as the target where that is valid and
// smaller only where needed. Starting from the targets, every round checks the shell exactly
// (tet orientation, boundary triangle intersections) and shrinks t_i by a constant factor at the
// top vertices of every violation; small enough thicknesses along valid directions are always
// valid when the base itself is (each prism's volume grows like t * area * (n_f . d_i) > 0 and the
// top stays within a thin neighbourhood of the embedded base), so the rounds end.
#include <gshell/guard/extrusion_directions.h>
#include <gshell/quality/shell_boundary.h>

#include <Eigen/Core>
#include <utility>
#include <vector>

namespace gshell {

struct ValidStartOptions {
  double thinning = 0.5; ///< factor applied to t_i of a vertex in a violation, per round, in (0, 1)
  int max_rounds = 40;   ///< rounds before giving up (a violation that survives 2^-40 of the target
                         ///< thickness comes from the base itself, e.g. touching input triangles)
};

struct ValidStart {
  Eigen::MatrixXd top;        ///< n x 3
  Eigen::VectorXd thickness;  ///< t_i (model units)
  int rounds = 0;             ///< checks run
  /// What the last check still found (empty unless max_rounds ran out): tets that are not skipped
  /// and pairs of boundary rows of which neither is excluded (base/base pairs are not reported).
  std::vector<int> inverted_tets;
  std::vector<std::pair<int, int>> intersections;
  double seconds = 0;
};

/// The start for the base (V, F) with directions `directions` and target thicknesses `target` (n
/// values, model units). `boundary` = shell_boundary(F, n); `skip_tets` (one flag per tet of
/// build_prism_tets, or empty) and `excluded_triangles` (one flag per boundary row, or empty):
/// violations involving only those are ignored (they cannot be mended by thinning).
ValidStart valid_start(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const ExtrusionDirections& directions,
                       const Eigen::VectorXd& target, const ShellBoundary& boundary,
                       const std::vector<char>& skip_tets = {}, const std::vector<char>& excluded_triangles = {},
                       const ValidStartOptions& options = {});

} // namespace gshell
