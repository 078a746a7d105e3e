#pragma once
// Helpers the benchmarks share (header-only: each bench/*.cpp is its own executable).
#include <gshell/deform/handles.h>
#include <gshell/deform/pose.h>
#include <gshell/io/load_mesh.h>
#include <gshell/shell/generate_shell.h>
#include <gshell/shell/shell.h>

#include <Eigen/Core>

#include <algorithm>
#include <limits>
#include <vector>

namespace gshell::bench {

/// The rest shell as `gshell generate --method rigid --thickness-ratio RATIO` makes it (no
/// intersection counts), for the deformation benchmarks.
inline GenerateResult rigid_rest_shell(const TriMesh& mesh, double ratio) {
  GenerateOptions generate;
  generate.method = ShellMethod::Rigid;
  generate.thickness = thickness_from_ratio(mesh.V, ratio);
  generate.count_intersections = false;
  return generate_shell(mesh.V, mesh.F, generate);
}

/// Median of the values (mean of the middle two for an even count; NaN when empty).
inline double median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  const std::size_t h = v.size() / 2;
  return v.size() % 2 ? v[h] : 0.5 * (v[h - 1] + v[h]);
}

/// The pull the pose benchmarks share (R = half the largest bounding-box side). Bowl: hold the
/// rim on one side (x < -0.5 R, z > -0.15 R, both surfaces), pull the rim on the other side
/// (x > 0.7 R) by R (0.8, 0.2, 0.5). Other shells: hold the lowest 8% along y, pull the highest
/// 8% by R (0.5, 0.1, 0.3). Handle centers are their vertices' centroids.
inline HandleSet pull_handles(const Shell& shell, bool bowl) {
  const Eigen::MatrixXd X = shell.vertices();
  const Eigen::RowVector3d lo = X.colwise().minCoeff(), hi = X.colwise().maxCoeff();
  const double R = 0.5 * (hi - lo).maxCoeff();
  Handle hold, pull;
  for (int v = 0; v < X.rows(); ++v) {
    const Eigen::RowVector3d p = X.row(v);
    if (bowl) {
      if (p.z() > -0.15 * R && p.x() < -0.5 * R) hold.vertices.push_back(v);
      if (p.z() > -0.15 * R && p.x() > 0.7 * R) pull.vertices.push_back(v);
    } else {
      const double y = (p.y() - lo.y()) / (hi.y() - lo.y());
      if (y < 0.08) hold.vertices.push_back(v);
      if (y > 0.92) pull.vertices.push_back(v);
    }
  }
  pull.translate = bowl ? Eigen::Vector3d(0.8 * R, 0.2 * R, 0.5 * R) : Eigen::Vector3d(0.5 * R, 0.1 * R, 0.3 * R);
  HandleSet set;
  set.handles = {hold, pull};
  for (auto& h : set.handles) {
    h.center = Eigen::Vector3d::Zero();
    for (int v : h.vertices) h.center += X.row(v).transpose();
    h.center /= static_cast<double>(h.vertices.size());
  }
  return set;
}

/// The pose benchmarks' reference solver: the single level with Anderson(5) acceleration (the
/// same minimum as plain local/global, reached much sooner), no path extrapolation.
inline PoseSolver reference_pose_solver(const Shell& shell, const HandleSet& handles) {
  HierarchyOptions o;
  o.levels = 1;
  o.anderson_history = 5;
  o.path_extrapolation = false;
  return PoseSolver(shell, handles, PoseSolverKind::Hierarchical, o);
}

} // namespace gshell::bench
