#pragma once
// A valid start for the guarded solver: the top vertex i at b_i + s_i w_i, w_i an extrusion vector
// that sees every face at vertex i from its positive side (n_f . w_i > 0), with per-vertex scales
// s_i in (0, 1] as large as is valid. Starting from s = 1 (the wanted top: the paper's unguarded
// result where its directions are valid), every round checks the shell exactly (tet orientation,
// boundary triangle intersections) and shrinks s_i by a constant factor at the top vertices of
// every violation. Small enough scales along valid vectors are always valid when the base itself
// is (each prism's tets gain volume like s * area * (n_f . w_i) > 0 and the top stays within a
// thin neighbourhood of the embedded base), so the rounds end, touching only where needed.
#include <gshell/guard/extrusion_directions.h>
#include <gshell/quality/shell_boundary.h>

#include <Eigen/Core>
#include <utility>
#include <vector>

namespace gshell {

/// Extrusion vectors towards a wanted top (n x 3): w_i = top_i - b_i where that direction keeps a
/// margin of at least min_margin (cosine) on every face at vertex i, otherwise |top_i - b_i| (or
/// `fallback_length` if that is 0) along directions.direction. Unused vertices get 0.
Eigen::MatrixXd extrusion_vectors(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& top,
                                  const ExtrusionDirections& directions, double min_margin, double fallback_length);

struct ValidStartOptions {
  double thinning = 0.5; ///< factor applied to s_i of a vertex in a violation, per round, in (0, 1)
  int max_rounds = 40;   ///< rounds before giving up (a violation that survives 2^-40 of the target
                         ///< thickness comes from the base itself, e.g. touching input triangles)
};

struct ValidStart {
  Eigen::MatrixXd top;        ///< n x 3
  Eigen::VectorXd scale;      ///< s_i
  int rounds = 0;             ///< checks run
  /// What the last check still found (empty unless max_rounds ran out): tets that are not skipped
  /// and pairs of boundary rows of which neither is excluded (base/base pairs are not reported).
  std::vector<int> inverted_tets;
  std::vector<std::pair<int, int>> intersections;
  double seconds = 0;
};

/// The start for the base (V, F) along extrusion vectors W (n x 3, extrusion_vectors).
/// `skip_tets` (one flag per tet of build_prism_tets, or empty) and `excluded_triangles` (one flag
/// per row of shell_boundary(F, n), or empty): violations involving those are ignored (they cannot
/// be mended by thinning). The checks are the certificate's (certify_shell), without base/base pairs.
ValidStart valid_start(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& W,
                       const std::vector<char>& skip_tets = {}, const std::vector<char>& excluded_triangles = {},
                       const ValidStartOptions& options = {});

} // namespace gshell
