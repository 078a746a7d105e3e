#include "shell_validity.h"

#include <gshell/quality/triangle_intersections.h>
#include <gshell/shell/prism_tets.h>

#include <Eigen/Dense>

#include <chrono>

namespace gshell {

nlohmann::ordered_json ShellValidity::to_json() const {
  return {{"inverted_tets", inverted_tets},
          {"intersections", {{"top_self", top_self_intersections}, {"top_base", top_base_intersections}}},
          {"valid", valid()},
          {"seconds", seconds}};
}

ShellValidity measure_shell_validity(const Eigen::MatrixXd& X, const Eigen::MatrixXi& F) {
  const auto start = std::chrono::steady_clock::now();
  const Eigen::Index n = X.rows() / 2;
  const Eigen::MatrixXd base = X.topRows(n), top = X.bottomRows(n);
  ShellValidity v;
  // The prism tets are positively oriented at rest by construction: a tet is inverted where its
  // signed volume is no longer positive.
  const Eigen::MatrixXi T = build_prism_tets(F, static_cast<int>(n));
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    const Eigen::RowVector3d x0 = X.row(T(t, 0));
    Eigen::Matrix3d D;
    D << X.row(T(t, 1)) - x0, X.row(T(t, 2)) - x0, X.row(T(t, 3)) - x0;
    if (!(D.determinant() > 0)) ++v.inverted_tets;
  }
  v.top_self_intersections = count_self_intersections(top, F);
  v.top_base_intersections = count_intersections_between(top, F, base, F);
  v.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return v;
}

} // namespace gshell
