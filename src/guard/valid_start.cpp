#include <gshell/guard/valid_start.h>

#include <gshell/error.h>
#include <gshell/shell/prism_tets.h>

#include "guard/start_check.h"

#include <chrono>

namespace gshell {

ValidStart valid_start(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const ExtrusionDirections& directions,
                       const Eigen::VectorXd& target, const ShellBoundary& boundary,
                       const std::vector<char>& skip_tets, const std::vector<char>& excluded_triangles,
                       const ValidStartOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const int n = static_cast<int>(V.rows());
  if (target.size() != n || directions.direction.rows() != n)
    throw InputError("valid_start: expected one direction and one target thickness per vertex");
  if (!(options.thinning > 0 && options.thinning < 1)) throw InputError("valid_start: thinning must be in (0, 1)");
  const Eigen::MatrixXi T = build_prism_tets(F, n);
  auto skipped = [&](int t) { return !skip_tets.empty() && skip_tets[t]; };
  auto excluded = [&](int row) { return !excluded_triangles.empty() && excluded_triangles[row]; };

  ValidStart s;
  s.thickness = target;
  Eigen::MatrixXd X(2 * n, 3);
  std::vector<char> thin(n);
  for (s.rounds = 1;; ++s.rounds) {
    s.top = V + s.thickness.asDiagonal() * directions.direction;
    X << V, s.top;
    const detail::StartViolations found = detail::start_violations(X, T, boundary);
    s.inverted_tets.clear();
    s.intersections.clear();
    std::fill(thin.begin(), thin.end(), 0);
    for (int t : found.inverted_tets) {
      if (skipped(t)) continue;
      s.inverted_tets.push_back(t);
      for (int j = 0; j < 4; ++j)
        if (T(t, j) >= n) thin[T(t, j) - n] = 1;
    }
    for (const auto& [a, b] : found.intersections) {
      if (excluded(a) || excluded(b)) continue;
      s.intersections.emplace_back(a, b);
      for (int row : {a, b})
        for (int k = 0; k < 3; ++k)
          if (boundary.F(row, k) >= n) thin[boundary.F(row, k) - n] = 1;
    }
    if ((s.inverted_tets.empty() && s.intersections.empty()) || s.rounds >= options.max_rounds) break;
    for (int i = 0; i < n; ++i)
      if (thin[i]) s.thickness[i] *= options.thinning;
  }
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

} // namespace gshell
