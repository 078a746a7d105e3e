#pragma once
// The quality report of a shell (docs/design.md "Quality measures"), for any base/top pair.
#include <gshell/quality/shell_certificate.h>
#include <gshell/quality/stretch.h>
#include <gshell/eigen_abi.h>
#include <Eigen/Core>

namespace gshell {

/// A top vertex is "thinned" when its thickness (distance to the base surface) is below this
/// fraction of the target eta.
constexpr double kThinnedFraction = 0.9;

struct ShellMetrics {
  /// Per-tet stretch against the ideal normal prisms of thickness eta. Its `inverted` counts
  /// det F <= 0 in doubles; the exact count, the one the reports give, is the certificate's.
  StretchStats stretch;
  Eigen::VectorXd tet_stretch;     ///< 3m values, tets in build_prism_tets order
  Eigen::VectorXd tet_determinant; ///< det F per tet against the normal prisms (<= 0: inverted)
  /// Exact validity (quality/shell_certificate.h), base/base pairs included. Without
  /// intersection counts only its tets are checked (pair counts -1).
  ShellCertificate certificate;
  Eigen::VectorXd vertex_thickness; ///< distance of each top vertex to the base surface / eta
  /// Of vertex_thickness (relative to eta), over the vertices some face uses.
  double thickness_min = 0, thickness_mean = 0;
  int thinned_vertices = 0; ///< used top vertices with vertex_thickness < kThinnedFraction
};

/// Measures the shell between `base` and `top` (same faces F, top vertex i over base vertex i)
/// for thickness eta (model units, > 0). Intersections (the certificate's pair tests) are counted
/// only if asked.
/// \throws InputError when eta is not positive and finite, base and top differ in shape or are not
///         n x 3 and finite, or F is not m x 3 with three distinct ids in [0, n) per face.
ShellMetrics shell_metrics(const Eigen::MatrixXd& base, const Eigen::MatrixXi& F, const Eigen::MatrixXd& top,
                           double eta, bool count_intersections = true);

/// The same with the rest tets of the normal prisms already built
/// (prism_rest_tets(F, n, normal_prisms(base, F, eta))), e.g. by the rigid method's solver.
/// \throws InputError as above, and when normal_rest does not hold 3 tets per face.
ShellMetrics shell_metrics(const Eigen::MatrixXd& base, const Eigen::MatrixXi& F, const Eigen::MatrixXd& top,
                           double eta, bool count_intersections, const RestTets& normal_rest);

} // namespace gshell
