#include <gshell/deform/shell_deformer.h>

#include <gshell/error.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/solver/polar_decomposition.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <numeric>

namespace gshell {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

RestTets rest_of(const Shell& shell) {
  return rest_tets_from_positions(shell.vertices(), build_prism_tets(shell.F, shell.num_base_vertices()));
}

std::vector<int> base_ids(int n) {
  std::vector<int> ids(n);
  std::iota(ids.begin(), ids.end(), 0);
  return ids;
}

} // namespace

const char* warm_start_name(WarmStart w) {
  switch (w) {
  case WarmStart::PreviousTop: return "previous";
  case WarmStart::Translated: return "translated";
  case WarmStart::RotatedOffset: return "rotated";
  }
  return "?";
}

WarmStart parse_warm_start(const std::string& name) {
  if (name == "previous") return WarmStart::PreviousTop;
  if (name == "translated") return WarmStart::Translated;
  if (name == "rotated") return WarmStart::RotatedOffset;
  throw InputError("unknown warm start '" + name + "' (previous, translated, rotated)");
}

std::vector<std::vector<int>> vertex_neighbours(const Eigen::MatrixXi& F, int n) {
  std::vector<std::vector<int>> rings(n);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int a = F(f, c), b = F(f, (c + 1) % 3);
      rings[a].push_back(b);
      rings[b].push_back(a);
    }
  for (auto& r : rings) {
    std::sort(r.begin(), r.end());
    r.erase(std::unique(r.begin(), r.end()), r.end());
  }
  return rings;
}

Eigen::MatrixXd rotated_offset_top(const Eigen::MatrixXd& old_base, const Eigen::MatrixXd& old_top,
                                   const Eigen::MatrixXd& new_base, const Eigen::MatrixXi& F,
                                   const std::vector<std::vector<int>>& neighbours) {
  const Eigen::MatrixXd old_normals = vertex_normals(old_base, F), new_normals = vertex_normals(new_base, F);
  const int n = static_cast<int>(old_base.rows());
  Eigen::MatrixXd top(n, 3);
  tbb::parallel_for(0, n, [&](int i) {
    Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
    double length = 0;
    const Eigen::RowVector3d p = old_base.row(i), q = new_base.row(i);
    for (int j : neighbours[i]) {
      const Eigen::RowVector3d dp = old_base.row(j) - p, dq = new_base.row(j) - q;
      C += dq.transpose() * dp;
      length += dp.norm();
    }
    if (!neighbours[i].empty()) length /= static_cast<double>(neighbours[i].size());
    C += length * length * new_normals.row(i).transpose() * old_normals.row(i);
    const Eigen::Matrix3d R = C.squaredNorm() > 0 ? closest_rotation(C) : Eigen::Matrix3d::Identity();
    top.row(i) = q + (R * (old_top.row(i) - p).transpose()).transpose();
  });
  return top;
}

ShellDeformer::ShellDeformer(const Shell& rest)
    : rest_(rest),
      solver_(rest_of(rest), 2 * rest.num_base_vertices(), base_ids(rest.num_base_vertices())),
      current_(rest.vertices()),
      neighbours_(vertex_neighbours(rest.F, rest.num_base_vertices())) {}

void ShellDeformer::reset() { current_ = rest_.vertices(); }

FrameResult ShellDeformer::solve(const Eigen::MatrixXd& new_base, const DeformOptions& options) {
  const int n = rest_.num_base_vertices();
  if (new_base.rows() != n || new_base.cols() != 3)
    throw InputError("the new base has " + std::to_string(new_base.rows()) + " vertices, the shell's base has " +
                     std::to_string(n));
  if (!new_base.allFinite()) throw InputError("the new base has a non-finite coordinate");

  const auto start = Clock::now();
  const Eigen::MatrixXd old_base = current_.topRows(n), old_top = current_.bottomRows(n);
  Eigen::MatrixXd X(2 * n, 3);
  X.topRows(n) = new_base;
  switch (options.warm_start) {
  case WarmStart::PreviousTop: X.bottomRows(n) = old_top; break;
  case WarmStart::Translated: X.bottomRows(n) = old_top + (new_base - old_base); break;
  case WarmStart::RotatedOffset:
    X.bottomRows(n) = rotated_offset_top(old_base, old_top, new_base, rest_.F, neighbours_);
    break;
  }
  SolveOptions solve_options;
  solve_options.max_iterations = options.max_iterations;
  solve_options.tolerance = options.tolerance;
  const SolveResult solved = solver_.solve(X, solve_options);

  FrameResult result;
  result.seconds = seconds_since(start);
  result.iterations = solved.iterations;
  result.energy = solved.energy;
  result.converged = solved.converged;
  if (options.measure_stretch) {
    const auto stretch_start = Clock::now();
    result.stretch = stretch_stats(solver_.rest(), X);
    result.stretch_seconds = seconds_since(stretch_start);
  }
  result.top = X.bottomRows(n);
  current_ = std::move(X);
  return result;
}

} // namespace gshell
