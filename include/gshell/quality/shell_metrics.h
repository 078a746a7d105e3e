#pragma once
// The quality report of a shell (DESIGN.md "Quality measures"), for any base/top pair.
#include <gshell/quality/stretch.h>
#include <Eigen/Core>

namespace gshell {

struct ShellMetrics {
  StretchStats stretch;            ///< per-tet stretch against the ideal normal prisms of thickness eta
  Eigen::VectorXd tet_stretch;     ///< 3m values, tets in build_prism_tets order
  Eigen::VectorXd tet_determinant; ///< det F per tet against the normal prisms (<= 0: inverted)
  int top_self_intersections = -1; ///< pairs of top faces sharing no vertex that intersect; -1 = not counted
  int top_base_intersections = -1; ///< pairs (top face, base face) that intersect; -1 = not counted
  Eigen::VectorXd vertex_thickness; ///< distance of each top vertex to the base surface / eta
  double thickness_min = 0, thickness_mean = 0; ///< of vertex_thickness (relative to eta)
};

/// Measures the shell between `base` and `top` (same faces F, top vertex i over base vertex i)
/// for thickness eta (model units, > 0). Intersections are counted only if asked (they dominate
/// the cost on big meshes). Throws InputError on mismatched sizes or eta <= 0.
ShellMetrics shell_metrics(const Eigen::MatrixXd& base, const Eigen::MatrixXi& F, const Eigen::MatrixXd& top,
                           double eta, bool count_intersections = true);

/// The same with the rest tets of the normal prisms already built
/// (prism_rest_tets(F, n, normal_prisms(base, F, eta))), e.g. by the rigid method's solver.
ShellMetrics shell_metrics(const Eigen::MatrixXd& base, const Eigen::MatrixXi& F, const Eigen::MatrixXd& top,
                           double eta, bool count_intersections, const RestTets& normal_rest);

} // namespace gshell
