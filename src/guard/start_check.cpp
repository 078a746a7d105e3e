#include "guard/start_check.h"

#include <gshell/quality/triangle_intersections.h>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

namespace gshell::detail {

StartViolations start_violations(const Eigen::MatrixXd& X, const Eigen::MatrixXi& T, const ShellBoundary& boundary) {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  StartViolations v;
  auto point = [&](int i) { return K::Point_3(X(i, 0), X(i, 1), X(i, 2)); };
  for (int t = 0; t < T.rows(); ++t)
    if (CGAL::orientation(point(T(t, 0)), point(T(t, 1)), point(T(t, 2)), point(T(t, 3))) != CGAL::POSITIVE)
      v.inverted_tets.push_back(t);
  for (const auto& [a, b] : self_intersecting_pairs(X, boundary.F))
    if (boundary.part[a] != BoundaryPart::Base || boundary.part[b] != BoundaryPart::Base)
      v.intersections.emplace_back(a, b);
  return v;
}

} // namespace gshell::detail
