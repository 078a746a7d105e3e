#include <gshell/guard/valid_start.h>

#include <gshell/error.h>
#include <gshell/shell/prism_tets.h>

#include "guard/start_check.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>

namespace gshell {

Eigen::MatrixXd extrusion_vectors(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& top,
                                  const ExtrusionDirections& directions, double min_margin, double fallback_length) {
  const int n = static_cast<int>(V.rows());
  if (top.rows() != n || directions.direction.rows() != n)
    throw InputError("extrusion_vectors: expected one top vertex and one direction per base vertex");
  Eigen::MatrixXd W = top - V;
  // The smallest cosine between each wanted vector and the normals of the faces around it.
  Eigen::VectorXd margin = Eigen::VectorXd::Constant(n, 2.0);
  for (int f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    const Eigen::Vector3d x = (b - a).cross(c - a);
    if (!(x.norm() > 0)) continue;
    const Eigen::Vector3d normal = x.normalized();
    for (int k = 0; k < 3; ++k) {
      const int v = F(f, k);
      const double len = W.row(v).norm();
      margin[v] = std::min(margin[v], len > 0 ? W.row(v).dot(normal) / len : -1.0);
    }
  }
  for (int v = 0; v < n; ++v) {
    if (margin[v] > 1.5) { // no face: not part of the shell
      W.row(v).setZero();
      continue;
    }
    if (margin[v] >= min_margin) continue;
    const double len = W.row(v).norm();
    W.row(v) = (len > 0 ? len : fallback_length) * directions.direction.row(v);
  }
  return W;
}

ValidStart valid_start(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& W,
                       const std::vector<char>& skip_tets, const std::vector<char>& excluded_triangles,
                       const ValidStartOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const int n = static_cast<int>(V.rows());
  if (W.rows() != n || W.cols() != 3) throw InputError("valid_start: expected one extrusion vector per vertex");
  if (!(options.thinning > 0 && options.thinning < 1)) throw InputError("valid_start: thinning must be in (0, 1)");
  const detail::StartChecker checker(F, n, skip_tets, excluded_triangles);
  const Eigen::MatrixXi& T = checker.tets();
  const ShellBoundary& boundary = checker.boundary();

  ValidStart s;
  s.scale = Eigen::VectorXd::Ones(n);
  std::vector<char> thin(n), moved(n, 0);
  for (s.rounds = 1;; ++s.rounds) {
    s.top = V + s.scale.asDiagonal() * W;
    // The first round checks everything, later ones what the last thinning moved.
    const detail::StartViolations found = checker.check(V, s.top, s.rounds == 1 ? nullptr : &moved);
    s.inverted_tets = found.inverted_tets;
    s.intersections = found.intersections;
    std::fill(thin.begin(), thin.end(), 0);
    for (int t : found.inverted_tets)
      for (int j = 0; j < 4; ++j)
        if (T(t, j) >= n) thin[T(t, j) - n] = 1;
    for (const auto& [a, b] : found.intersections)
      for (int row : {a, b})
        for (int k = 0; k < 3; ++k)
          if (boundary.F(row, k) >= n) thin[boundary.F(row, k) - n] = 1;
    if ((s.inverted_tets.empty() && s.intersections.empty()) || s.rounds >= options.max_rounds) break;
    for (int i = 0; i < n; ++i) {
      moved[i] = thin[i];
      if (thin[i]) s.scale[i] *= options.thinning;
    }
  }
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

} // namespace gshell
