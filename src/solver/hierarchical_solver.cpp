#include <gshell/solver/hierarchical_solver.h>

#include "hierarchy_levels.h"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <stdexcept>
#include <string>

namespace gshell {

using detail::FullLevel;
using detail::LocalCache;
using detail::ReducedLevel;
using detail::RigidChange;

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

/// The reduced levels rely on the rest shapes being the tets of `rest_vertices` (then a tet inside
/// a cluster has F = M exactly); a mismatch would silently solve another problem.
void require_matching_rest(const RestTets& rest, const Eigen::MatrixXd& X) {
  for (int t = 0; t < rest.size(); ++t) {
    Eigen::Matrix3d D;
    for (int k = 0; k < 3; ++k) D.col(k) = (X.row(rest.T(t, k + 1)) - X.row(rest.T(t, 0))).transpose();
    if (((D * rest.Dm_inv[t]) - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6)
      throw std::invalid_argument("HierarchicalSolver: rest shapes do not match rest_vertices at tet " +
                                  std::to_string(t));
  }
}

} // namespace

double mean_stiffness(const RestTets& rest, int num_vertices) {
  if (num_vertices <= 0) return 0;
  return detail::stiffness_matrix(rest, num_vertices).diagonal().sum() / num_vertices;
}

struct HierarchicalSolver::Impl {
  RestTets rest;
  PositionConstraints constraints;
  HierarchyOptions options;
  ClusterTree tree;
  std::vector<int> depth_of_level;
  std::unique_ptr<FullLevel> full;
  std::vector<ReducedLevel> reduced;
  std::vector<LocalCache> reduced_cache;
  std::vector<Eigen::MatrixXd> tau;  // per reduced level: fine residual coupling of this outer iteration
  double factor_seconds = 0;

  int num_vertices() const { return static_cast<int>(rest_vertices_rows); }
  int rest_vertices_rows = 0;

  /// The objective of reduced level l: its energy minus 2 <tau_l, z> (tau_l = 0 without residual correction).
  double reduced_objective(int l, const Eigen::MatrixXd& targets, const LocalCache& cache) const {
    double e = cache.elastic + reduced[l].springs(targets);
    if (tau[l].size() > 0) e -= 2.0 * tau[l].cwiseProduct(reduced[l].parameters()).sum();
    return e;
  }

  /// One reduced level within an outer iteration: take the parent's change if it does not raise
  /// this level's objective, then a few local/global iterations.
  int solve_reduced(int l, const std::vector<RigidChange>* parent_change, const Eigen::MatrixXd& targets) {
    ReducedLevel& level = reduced[l];
    LocalCache& cache = reduced_cache[l];
    int rejected = 0;
    if (parent_change) {
      const double energy = reduced_objective(l, targets, cache);
      const Eigen::MatrixXd kept = level.parameters();
      level.apply(*parent_change, parent_of(l));
      LocalCache candidate;
      level.local(candidate);
      if (reduced_objective(l, targets, candidate) <= energy) {
        std::swap(candidate, cache);
      } else {
        level.parameters() = kept;
        ++rejected;
      }
    }
    for (int k = 0; k < options.level_iterations; ++k) {
      Eigen::MatrixXd rhs = level.rhs(targets, cache);
      if (tau[l].size() > 0) rhs += tau[l];
      level.solve(rhs);
      level.local(cache);
    }
    return rejected;
  }

  /// Parent (at the previous reduced level) of every cluster of reduced level l > 0.
  std::vector<int> parent_of(int l) const {
    const int d0 = depth_of_level[l - 1], d1 = depth_of_level[l];
    std::vector<int> p(tree.num_clusters(d1));
    for (int c = 0; c < static_cast<int>(p.size()); ++c) {
      int q = c;
      for (int d = d1; d > d0; --d) q = tree.parent[d][q];
      p[c] = q;
    }
    return p;
  }
};

HierarchicalSolver::HierarchicalSolver(const RestTets& rest, const Eigen::MatrixXd& rest_vertices,
                                       const Eigen::MatrixXi& F, const PositionConstraints& constraints,
                                       const HierarchyOptions& options)
    : impl_(std::make_unique<Impl>()) {
  const auto start = Clock::now();
  Impl& s = *impl_;
  s.rest = rest;
  s.constraints = constraints;
  s.options = options;
  s.rest_vertices_rows = static_cast<int>(rest_vertices.rows());
  if (options.levels < 1) throw std::invalid_argument("HierarchicalSolver: levels must be >= 1");
  if (rest_vertices.rows() % 2 != 0) throw std::invalid_argument("HierarchicalSolver: rest_vertices must have 2n rows");
  if (!constraints.hard && !(constraints.weight > 0))
    throw std::invalid_argument("HierarchicalSolver: soft constraints need a positive weight");
  require_matching_rest(s.rest, rest_vertices);

  s.full = std::make_unique<FullLevel>(s.rest, s.num_vertices(), constraints);

  const int reduced_levels = options.levels - 1;
  const int split = std::max(1, options.splits_per_level);
  ClusterTreeOptions tree_options;
  tree_options.depth = reduced_levels > 0 ? (reduced_levels - 1) * split : 0;
  tree_options.min_cluster_size = options.min_cluster_size;
  s.tree = build_cluster_tree(rest_vertices, F, tree_options);
  const double weight = constraints.hard ? options.reduced_hard_weight * mean_stiffness(s.rest, s.num_vertices())
                                         : constraints.weight;
  for (int l = 0; l < reduced_levels; ++l) {
    const int d = l * split;
    s.depth_of_level.push_back(d);
    s.reduced.emplace_back(s.rest, rest_vertices, s.tree.cluster_of[d], s.tree.num_clusters(d),
                           s.full->stiffness(), constraints.vertices, weight);
  }
  s.reduced_cache.resize(reduced_levels);
  s.tau.resize(reduced_levels);
  s.factor_seconds = seconds_since(start);
}

HierarchicalSolver::~HierarchicalSolver() = default;
HierarchicalSolver::HierarchicalSolver(HierarchicalSolver&&) noexcept = default;
HierarchicalSolver& HierarchicalSolver::operator=(HierarchicalSolver&&) noexcept = default;

HierarchicalSolveResult HierarchicalSolver::solve(Eigen::MatrixXd& X, const Eigen::MatrixXd& targets,
                                                  const SolveOptions& options) {
  Impl& s = *impl_;
  const auto start = Clock::now();
  if (X.rows() != s.num_vertices() || X.cols() != 3)
    throw std::invalid_argument("HierarchicalSolver::solve: X must be 2n x 3");
  if (targets.rows() != static_cast<Eigen::Index>(s.constraints.vertices.size()) || targets.cols() != 3)
    throw std::invalid_argument("HierarchicalSolver::solve: one target row per constrained vertex");

  const FullLevel& full = *s.full;
  full.set_hard_rows(X, targets);
  LocalCache current, candidate;
  full.local(X, current);
  double energy = current.elastic + full.springs(X, targets);

  HierarchicalSolveResult result;
  result.energy.push_back(energy);
  const int L = static_cast<int>(s.reduced.size());
  bool use_hierarchy = L > 0;
  std::vector<Eigen::MatrixXd> before(L);
  Eigen::MatrixXd trial;
  for (int it = 1; it <= options.max_iterations; ++it) {
    const double previous = energy;
    if (use_hierarchy) {
      Eigen::MatrixXd fine_gradient;
      if (s.options.residual_correction) fine_gradient = full.half_gradient(X, targets, current);
      for (int l = 0; l < L; ++l) {
        if (s.options.residual_correction) {
          s.reduced[l].fit(X);
          s.reduced[l].local(s.reduced_cache[l]);
        }
        before[l] = s.reduced[l].parameters();
        if (!s.reduced_cache[l].valid) s.reduced[l].local(s.reduced_cache[l]);
        // tau makes the level's gradient at its current state equal the fine gradient seen
        // through its subspace, so it moves to reduce the fine residual (FAS coupling).
        s.tau[l].resize(0, 0);
        if (s.options.residual_correction)
          s.tau[l] = s.reduced[l].half_gradient(targets, s.reduced_cache[l]) - s.reduced[l].restrict_field(fine_gradient);
      }
      std::vector<RigidChange> change;
      for (int l = 0; l < L; ++l) {
        result.rejected_propagations += s.solve_reduced(l, l > 0 ? &change : nullptr, targets);
        change = s.reduced[l].changes_since(before[l]);
      }
      // Push the finest reduced level's change into the full state; keep it only if E drops.
      const int n = s.num_vertices() / 2;
      trial = X;
      static const bool affine = getenv("AFFINE") != nullptr;
      if (affine) {
        Eigen::MatrixXd now = s.reduced.back().positions();
        s.reduced.back().parameters().swap(before.back());
        Eigen::MatrixXd was = s.reduced.back().positions();
        s.reduced.back().parameters().swap(before.back());
        trial += now - was;
      } else
      for (int v = 0; v < s.num_vertices(); ++v) {
        const RigidChange& c = change[s.tree.cluster_of[s.depth_of_level.back()][v < n ? v : v - n]];
        trial.row(v) = c.apply(X.row(v).transpose()).transpose();
      }
      full.set_hard_rows(trial, targets);
      full.local(trial, candidate);
      const double e = candidate.elastic + full.springs(trial, targets);
      if (getenv("DBG")) fprintf(stderr, "  prop: E %.8g -> %.8g\n", energy, e);
      if (e <= energy) {
        X.swap(trial);
        std::swap(current, candidate);
        energy = e;
      } else {
        ++result.rejected_propagations;
        // The coarse levels no longer help this solve: finish with plain full iterations.
        use_hierarchy = false;
      }
    }
    for (int k = 0; k < s.options.full_iterations; ++k) {
      trial = X;
      full.global(trial, targets, current);
      full.local(trial, candidate);
      ++result.full_iterations;
      const double e = candidate.elastic + full.springs(trial, targets);
      if (!(e <= energy)) break; // only rounding can make a local/global step go up
      X.swap(trial);
      std::swap(current, candidate);
      energy = e;
    }
    result.iterations = it;
    result.energy.push_back(energy);
    result.seconds = seconds_since(start);
    if (options.progress) options.progress(it, energy, result.seconds);
    if (previous <= 0 || (previous - energy) / previous < options.tolerance) {
      result.converged = true;
      break;
    }
  }
  result.seconds = seconds_since(start);
  return result;
}

double HierarchicalSolver::energy(const Eigen::MatrixXd& X, const Eigen::MatrixXd& targets) const {
  LocalCache cache;
  impl_->full->local(X, cache);
  return cache.elastic + impl_->full->springs(X, targets);
}

void HierarchicalSolver::reset() {
  for (auto& level : impl_->reduced) level.reset();
  for (auto& cache : impl_->reduced_cache) cache.valid = false;
}

int HierarchicalSolver::num_levels() const { return static_cast<int>(impl_->reduced.size()) + 1; }
const ClusterTree& HierarchicalSolver::tree() const { return impl_->tree; }
int HierarchicalSolver::tree_depth(int level) const { return impl_->depth_of_level.at(level); }
int HierarchicalSolver::num_clusters(int level) const { return impl_->reduced.at(level).num_clusters(); }
Eigen::MatrixXd HierarchicalSolver::level_positions(int level) const { return impl_->reduced.at(level).positions(); }
const Eigen::MatrixXd& HierarchicalSolver::level_parameters(int level) const {
  return impl_->reduced.at(level).parameters();
}
double HierarchicalSolver::level_energy(int level, const Eigen::MatrixXd& targets) const {
  LocalCache cache;
  impl_->reduced.at(level).local(cache);
  return cache.elastic + impl_->reduced.at(level).springs(targets);
}
double HierarchicalSolver::factor_seconds() const { return impl_->factor_seconds; }

} // namespace gshell
