#include <gshell/solver/hierarchical_solver.h>

#include "anderson_history.h"
#include "hierarchy_levels.h"

#include <gshell/error.h>
#include <gshell/format_number.h>
#include <gshell/seconds_since.h>

#include <Eigen/Cholesky>

#include <chrono>
#include <algorithm>
#include <cmath>
#include <string>

namespace gshell {

using AndersonHistory = detail::AndersonHistory<double>;
using detail::LocalCache;
using detail::ReducedLevel;
using detail::RigidChange;

namespace {

// Anderson on a reduced level's parameters (before: the iterate, the level's parameters: its image;
// they become the combination, if there is one). A cluster's map rows are unitless and its
// translation row a length, so a plain dot product weighs the two by the model's size: a pose of
// a mesh scaled by 1024 took another path to the minimum. Scaled by the cluster radius, a row of
// either kind counts by how far it moves the vertices.
void extrapolate_parameters(AndersonHistory& anderson, ReducedLevel& level, Eigen::MatrixXd before,
                            Eigen::MatrixXd& combined) {
  const double r = level.cluster_radius();
  Eigen::MatrixXd image = level.parameters();
  for (int c = 0; c < level.num_clusters(); ++c) {
    before.middleRows<3>(4 * c) *= r;
    image.middleRows<3>(4 * c) *= r;
  }
  if (!anderson.extrapolate(before, image, combined)) return;
  for (int c = 0; c < level.num_clusters(); ++c) combined.middleRows<3>(4 * c) /= r;
  level.parameters().swap(combined);
}

using Clock = std::chrono::steady_clock;

/// The reduced levels rely on the rest shapes being the tets of `rest_vertices` (then a tet inside
/// a cluster has F = M exactly); a mismatch would silently solve another problem. Tets with a rest
/// shape of their own (RestTets::override_tets: a generated shell's flat or inverted tets, which
/// take their ideal shape) are the exception the levels treat as border tets.
void require_matching_rest(const RestTets& rest, const Eigen::MatrixXd& X) {
  for (int t = 0; t < rest.size(); ++t) {
    if (std::binary_search(rest.override_tets.begin(), rest.override_tets.end(), t)) continue;
    Eigen::Matrix3d D;
    for (int k = 0; k < 3; ++k) D.col(k) = (X.row(rest.T(t, k + 1)) - X.row(rest.T(t, 0))).transpose();
    if (((D * rest.dm_inv(t)) - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6)
      throw InputError("HierarchicalSolver: rest (the rest shapes) do not match rest_vertices at tet " +
                                  std::to_string(t));
  }
}

/// The full level's iterate with its local step (rotations, energy), and buffers for candidate
/// iterates that persist across iterations (fresh megabyte-sized buffers cost page faults).
struct FullState {
  Eigen::MatrixXd& X;
  LocalStep step, candidate;
  Eigen::MatrixXd image, accelerated;
  Eigen::MatrixXd checkpoint; // the iterate at the last path extrapolation
};

constexpr int kPathDoublings = 10; // a path extrapolation goes at most 2^10 - 1 times the path further

} // namespace

void HierarchyOptions::check() const {
  auto at_least = [](int value, int least, const char* name) {
    if (value < least)
      throw InputError(std::string("HierarchicalSolver: options.") + name + " must be >= " + std::to_string(least) +
                       " (got " + std::to_string(value) + ")");
  };
  at_least(levels, 1, "levels");
  at_least(splits_per_level, 1, "splits_per_level");
  at_least(coarsest_clusters, 1, "coarsest_clusters");
  at_least(finest_cluster_size, 1, "finest_cluster_size");
  at_least(min_cluster_size, 1, "min_cluster_size");
  at_least(coarse_period, 1, "coarse_period");
  at_least(level_iterations, 0, "level_iterations");
  at_least(full_iterations, 0, "full_iterations");
  at_least(first_coarse_iteration, 0, "first_coarse_iteration");
  if (!(level_tolerance >= 0 && level_tolerance <= 1))
    throw InputError("HierarchicalSolver: options.level_tolerance must be in [0, 1] (got " + format_number(level_tolerance) + ")");
  // A negative weight made the reduced matrices indefinite ("not positive definite", not an input error).
  if (!(reduced_hard_weight > 0) || !std::isfinite(reduced_hard_weight))
    throw InputError("HierarchicalSolver: options.reduced_hard_weight must be positive and finite (got " +
                     format_number(reduced_hard_weight) + ")");
  check_anderson_history(anderson_history, "HierarchicalSolver: options.anderson_history");
  check_anderson_history(level_anderson_history, "HierarchicalSolver: options.level_anderson_history");
}

std::unique_ptr<ShellSolver> make_shell_solver(std::shared_ptr<const RestTets> rest, int num_vertices,
                                               const PositionConstraints& constraints) {
  if (constraints.hard) return std::make_unique<ShellSolver>(std::move(rest), num_vertices, constraints.vertices);
  SoftConstraints soft;
  soft.vertices = constraints.vertices;
  soft.weight = constraints.weight;
  return std::make_unique<ShellSolver>(std::move(rest), num_vertices, std::vector<int>{}, soft);
}

std::unique_ptr<ShellSolver> make_shell_solver(const RestTets& rest, int num_vertices,
                                               const PositionConstraints& constraints) {
  return make_shell_solver(std::make_shared<const RestTets>(rest), num_vertices, constraints);
}

double mean_stiffness(const RestTets& rest, int num_vertices) {
  if (num_vertices <= 0) return 0;
  // The diagonal alone: the whole matrix was a transient as large as the rest tets.
  double trace = 0;
  for (int t = 0; t < rest.size(); ++t) trace += rest.volume(t) * detail::gradient_rows(rest.dm_inv(t)).squaredNorm();
  return trace / num_vertices;
}

struct HierarchicalSolver::Impl {
  std::shared_ptr<const RestTets> rest; // shared with the full level; the reduced levels read it too
  PositionConstraints constraints;
  HierarchyOptions options;
  ClusterTree tree;
  std::vector<int> depth_of_level;
  /// parents[l][c]: the cluster of reduced level l-1 that holds cluster c of level l (l >= 1).
  std::vector<std::vector<int>> parents;
  std::shared_ptr<ShellSolver> full; // the full level: hard constraints eliminated, soft ones as springs
  std::vector<ReducedLevel> reduced;
  std::vector<LocalCache> reduced_cache;
  std::vector<Eigen::MatrixXd> tau;  // per reduced level: fine residual coupling of this outer iteration
  struct Preview {                   // anchor_preview / preview
    int level = -1;                  // -1: not anchored
    Eigen::MatrixXd anchor, z_anchor, tau, z_last;
    LocalCache cache;
  } preview;
  double factor_seconds = 0;
  HierarchyCounters counters; // since construction

  int num_vertices() const { return static_cast<int>(rest_vertices_rows); }
  int rest_vertices_rows = 0;

  /// What the full level takes as soft targets: the constraint targets in soft mode, none in hard.
  const Eigen::MatrixXd& soft_targets(const Eigen::MatrixXd& targets) const {
    return constraints.hard ? no_targets : targets;
  }
  Eigen::MatrixXd no_targets; // stays empty
  void set_hard_rows(Eigen::MatrixXd& X, const Eigen::MatrixXd& targets) const {
    if (!constraints.hard) return;
    for (size_t r = 0; r < constraints.vertices.size(); ++r) X.row(constraints.vertices[r]) = targets.row(r);
  }

  /// The objective of reduced level l: its energy minus 2 <tau_l, z> (tau_l = 0 without residual coupling).
  double reduced_objective(int l, const Eigen::MatrixXd& targets, const LocalCache& cache) const {
    double e = cache.elastic + reduced[l].springs(targets);
    if (tau[l].size() > 0) e -= 2.0 * tau[l].cwiseProduct(reduced[l].parameters()).sum();
    return e;
  }

  void reduced_iterations(int l, const Eigen::MatrixXd& targets) {
    ReducedLevel& level = reduced[l];
    LocalCache& cache = reduced_cache[l];
    double objective = options.level_tolerance > 0 ? reduced_objective(l, targets, cache) : 0;
    AndersonHistory anderson(options.level_anderson_history);
    Eigen::MatrixXd before, accelerated;
    for (int k = 0; k < options.level_iterations; ++k) {
      Eigen::MatrixXd rhs = level.rhs(targets, cache);
      if (tau[l].size() > 0) rhs += tau[l];
      before = level.parameters();
      level.solve(rhs);
      extrapolate_parameters(anderson, level, before, accelerated);
      // Only the last iteration's energy is read (unless the tolerance needs every one).
      level.local(cache, options.level_tolerance > 0 || k + 1 == options.level_iterations);
      if (options.level_tolerance > 0) {
        const double next = reduced_objective(l, targets, cache);
        // The objective (energy minus a linear term) can be negative: compare against the energy.
        const bool stalled = objective - next <= options.level_tolerance * std::abs(cache.elastic);
        objective = next;
        if (stalled) break;
      }
    }
  }

  /// The one point where a coarse correction enters the full state: `trial` (hard rows set) is
  /// kept only if it lowers the full energy, so the energy never rises across an accepted coarse
  /// correction. Returns whether it was kept (then state holds trial and its local step).
  bool accept_coarse_correction(FullState& state, Eigen::MatrixXd& trial, const Eigen::MatrixXd& targets) {
    full->local_step(trial, state.candidate, soft_targets(targets));
    if (!(state.candidate.energy < state.step.energy)) return false;
    state.X.swap(trial);
    std::swap(state.step, state.candidate);
    return true;
  }

  /// One coarse-to-fine pass over the reduced levels, ending in a candidate change of the full
  /// state, which is kept only if it lowers the full energy. Returns whether it was kept.
  bool coarse_correction(FullState& state, const Eigen::MatrixXd& targets) {
    const int L = static_cast<int>(reduced.size());
    const bool residual = options.residual_correction;
    std::vector<Eigen::MatrixXd> before(L);
    if (residual) {
      // Full approximation scheme: every level starts from the affine fit of the full state and
      // sees the full gradient through tau, so its fixed point is the full one's.
      // B^T X and B^T g pass over the vertices once, at the finest reduced level; the coarser
      // levels' come from summing its clusters' blocks up the tree.
      const Eigen::MatrixXd gradient = full->half_gradient(state.X, state.step, soft_targets(targets));
      Eigen::MatrixXd restricted_x = reduced[L - 1].restrict_field(state.X);
      Eigen::MatrixXd restricted_g = reduced[L - 1].restrict_field(gradient);
      for (int l = L - 1; l >= 0; --l) {
        if (l < L - 1) {
          restricted_x = reduced[l].coarsen(restricted_x, reduced[l + 1], parents[l + 1]);
          restricted_g = reduced[l].coarsen(restricted_g, reduced[l + 1], parents[l + 1]);
        }
        reduced[l].fit_restricted(restricted_x);
        reduced[l].local(reduced_cache[l]);
        before[l] = reduced[l].parameters();
        tau[l] = reduced[l].half_gradient(targets, reduced_cache[l]) - restricted_g;
      }
    } else {
      for (int l = 0; l < L; ++l) {
        before[l] = reduced[l].parameters();
        if (!reduced_cache[l].energy_valid) reduced[l].local(reduced_cache[l]);
      }
    }
    for (int l = 0; l < L; ++l) {
      if (l > 0) {
        // The parent's change since the start of this pass goes to its children first.
        ReducedLevel& level = reduced[l];
        const double objective = reduced_objective(l, targets, reduced_cache[l]);
        const Eigen::MatrixXd kept = level.parameters();
        if (residual) level.apply_change(reduced[l - 1], before[l - 1], parents[l]);
        else level.apply(reduced[l - 1].changes_since(before[l - 1]), parents[l]);
        LocalCache candidate;
        level.local(candidate);
        if (reduced_objective(l, targets, candidate) <= objective) {
          std::swap(candidate, reduced_cache[l]);
        } else {
          level.parameters() = kept;
          ++counters.rejected_propagations;
        }
      }
      reduced_iterations(l, targets);
    }

    // The finest reduced level's change goes into the full state.
    const ReducedLevel& finest = reduced.back();
    Eigen::MatrixXd trial;
    if (residual) {
      trial = state.X + finest.positions(finest.parameters() - before.back()); // B is linear in z
    } else {
      const std::vector<RigidChange> change = finest.changes_since(before.back());
      trial.resize(state.X.rows(), 3);
      for (int v = 0; v < state.X.rows(); ++v)
        trial.row(v) = change[finest.cluster_of_vertex(v)].apply(state.X.row(v).transpose()).transpose();
    }
    set_hard_rows(trial, targets);
    return accept_coarse_correction(state, trial, targets);
  }

  /// Anderson-accelerated local/global steps of the full level. Anderson records the pair
  /// (from, image), image = `steps` plain steps from state.X: from = state.X for the full level's
  /// own map, or under anderson_over_passes the iterate before this outer iteration's coarse pass
  /// (state.X holds the pass's result), a pair of the whole iteration's map. A combination is kept
  /// only if it lowers the energy; else the plain image, which cannot raise it. After a failed
  /// combination the full level's own history is cleared; the whole iteration's is kept (its
  /// pairs stay valid secants, and clearing them measured worse). Returns false when the plain
  /// image could not lower the energy either (converged to round-off).
  bool full_iteration(FullState& state, const Eigen::MatrixXd& targets, AndersonHistory& anderson,
                      const Eigen::MatrixXd& from, int steps, bool clear_on_failure) {
    const Eigen::MatrixXd& soft = soft_targets(targets);
    Eigen::MatrixXd& image = state.image;
    image = state.X;
    full->global_step(image, state.step, soft);
    for (int k = 1; k < steps; ++k) {
      full->local_step(image, state.candidate, soft);
      full->global_step(image, state.candidate, soft);
    }
    if (anderson.extrapolate(from, image, state.accelerated)) {
      full->local_step(state.accelerated, state.candidate, soft);
      if (state.candidate.energy < state.step.energy) {
        state.X.swap(state.accelerated);
        std::swap(state.step, state.candidate);
        return true;
      }
      if (clear_on_failure) anderson.clear();
    }
    full->local_step(image, state.candidate, soft);
    if (!(state.candidate.energy <= state.step.energy)) return false; // only round-off makes a plain step go up
    state.X.swap(image);
    std::swap(state.step, state.candidate);
    return true;
  }

  /// Line search along the path of the iterations: the displacement d since the last checkpoint is
  /// added again at 1, 2, 4, ... times its length, each step kept while it lowers the energy.
  /// Returns whether X moved. The iterate becomes the next checkpoint either way.
  bool extrapolate_path(FullState& state, const Eigen::MatrixXd& targets) {
    bool moved = false;
    if (state.checkpoint.size() == state.X.size()) {
      const Eigen::MatrixXd d = state.X - state.checkpoint;
      double scale = 1;
      for (int k = 0; k < kPathDoublings; ++k, scale *= 2) {
        state.accelerated = state.X + scale * d;
        set_hard_rows(state.accelerated, targets);
        full->local_step(state.accelerated, state.candidate, soft_targets(targets));
        if (!(state.candidate.energy < state.step.energy)) break;
        state.X.swap(state.accelerated);
        std::swap(state.step, state.candidate);
        moved = true;
      }
    }
    state.checkpoint = state.X;
    return moved;
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
    : HierarchicalSolver(std::make_shared<const RestTets>(rest), rest_vertices, F, constraints, options) {}

HierarchicalSolver::HierarchicalSolver(std::shared_ptr<const RestTets> shared_rest, const Eigen::MatrixXd& rest_vertices,
                                       const Eigen::MatrixXi& F, const PositionConstraints& constraints,
                                       const HierarchyOptions& options)
    : impl_(std::make_unique<Impl>()) {
  const auto start = Clock::now();
  if (!shared_rest) throw InputError("HierarchicalSolver: rest is null");
  Impl& s = *impl_;
  s.rest = std::move(shared_rest);
  const RestTets& rest = *s.rest;
  s.constraints = constraints;
  s.options = options;
  s.rest_vertices_rows = static_cast<int>(rest_vertices.rows());
  options.check();
  if (rest_vertices.rows() % 2 != 0) throw InputError("HierarchicalSolver: rest_vertices must have 2n rows (base then top), got " +
                     std::to_string(rest_vertices.rows()));
  if (!constraints.hard && !(constraints.weight > 0))
    throw InputError("HierarchicalSolver: constraints.weight must be > 0 for soft constraints (got " +
                     std::to_string(constraints.weight) + ")");
  // require_matching_rest and the cluster tree index rest_vertices by tet and face ids before
  // ShellSolver gets to check them.
  if (rest_vertices.cols() != 3) throw InputError("HierarchicalSolver: rest_vertices must have 3 columns, got " + std::to_string(rest_vertices.cols()));
  if (rest.T.size() > 0 && (rest.T.minCoeff() < 0 || rest.T.maxCoeff() >= rest_vertices.rows()))
    throw InputError("HierarchicalSolver: a tet of rest has a vertex id outside rest_vertices");
  if (F.size() > 0 && (F.cols() != 3 || F.minCoeff() < 0 || F.maxCoeff() >= rest_vertices.rows() / 2))
    throw InputError("HierarchicalSolver: F must be m x 3 with base vertex ids in [0, n)");
  require_matching_rest(rest, rest_vertices);

  s.full = make_shell_solver(s.rest, s.num_vertices(), constraints);
  const Eigen::SparseMatrix<double> L = detail::stiffness_matrix(rest, s.num_vertices());

  const int reduced_levels = options.levels - 1;
  const int split = std::max(1, options.splits_per_level);
  ClusterTreeOptions tree_options;
  // The coarsest reduced level has about coarsest_clusters clusters and each finer one is
  // splits_per_level bisection rounds down, but the finest has at least finest_cluster_size base
  // vertices per cluster (on small meshes the levels then move up, never above the root).
  const int n_base = s.num_vertices() / 2;
  const int by_size = static_cast<int>(std::lround(std::log2(std::max(1.0, static_cast<double>(n_base) /
                                                                          std::max(1, options.finest_cluster_size)))));
  const int top = static_cast<int>(std::lround(std::log2(std::max(1, options.coarsest_clusters))));
  const int finest = std::min(by_size, top + (reduced_levels - 1) * split);
  const int first = std::max(0, finest - (reduced_levels - 1) * split);
  // A tree deeper than log2(n) + 1 has stopped splitting (more levels than a mesh can hold were
  // asked for, e.g. --levels 40 on 162 vertices): levels below that, or any level with no more
  // clusters than the one above it, would repeat the same subspace at the cost of a factorisation
  // each, and are left out (num_levels() tells how many were built).
  const int deepest = static_cast<int>(std::ceil(std::log2(std::max(2, n_base)))) + 1;
  tree_options.depth = reduced_levels > 0 ? std::min(deepest, first + (reduced_levels - 1) * split) : 0;
  tree_options.min_cluster_size = options.min_cluster_size;
  s.tree = build_cluster_tree(rest_vertices, F, tree_options);
  const double weight = constraints.hard ? options.reduced_hard_weight * mean_stiffness(rest, s.num_vertices())
                                         : constraints.weight;
  // A flat rest shell (top = base) determines no cluster's affine map: the full level alone, as
  // the single-level solver (its rest tets are replaced by normal prisms, so it solves).
  for (int l = 0; l < reduced_levels && s.tree.spans_3d; ++l) {
    const int d = first + l * split;
    if (d > tree_options.depth || (l > 0 && s.tree.num_clusters(d) == s.reduced.back().num_clusters())) break;
    s.depth_of_level.push_back(d);
    const ClusterWeights weights = piecewise_cluster_weights(s.tree.cluster_of[d], s.tree.num_clusters(d));
    s.reduced.emplace_back(rest, rest_vertices, weights, s.tree.cluster_of[d], L, constraints.vertices, weight,
                           options.cluster_rotations);
  }
  const int built = static_cast<int>(s.reduced.size());
  s.parents.resize(built);
  for (int l = 1; l < built; ++l) s.parents[l] = s.parent_of(l);
  s.reduced_cache.resize(built);
  s.tau.resize(built);
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
    throw InputError("HierarchicalSolver::solve: X must be " + std::to_string(s.num_vertices()) + " x 3, got " +
                     std::to_string(X.rows()) + " x " + std::to_string(X.cols()));
  if (targets.rows() != static_cast<Eigen::Index>(s.constraints.vertices.size()) || targets.cols() != 3)
    throw InputError("HierarchicalSolver::solve: targets must be " + std::to_string(s.constraints.vertices.size()) +
                     " x 3 (one row per constrained vertex), got " + std::to_string(targets.rows()) + " x " +
                     std::to_string(targets.cols()));
  check_solve_limits(options, "HierarchicalSolver::solve");

  s.set_hard_rows(X, targets);
  FullState state{X, {}, {}, {}, {}, {}};
  s.full->local_step(X, state.step, s.soft_targets(targets));

  HierarchicalSolveResult result;
  const HierarchyCounters counted_before = s.counters;
  result.energy.push_back(state.step.energy);
  AndersonHistory anderson(s.options.anderson_history);
  int skip = 0, backoff = 1; // outer iterations to run without the reduced levels after a rejection
  const bool over_passes = s.options.anderson_over_passes && !s.reduced.empty() && s.options.coarse_period == 1 &&
                           s.options.full_iterations >= 1;
  Eigen::MatrixXd start_of_iteration;
  for (int it = 1; it <= options.max_iterations; ++it) {
    const double previous = state.step.energy;
    if (over_passes) start_of_iteration = state.X;
    const int period = std::max(1, s.options.coarse_period);
    if (!s.reduced.empty() && it % period == 0 && it >= s.options.first_coarse_iteration && skip-- <= 0) {
      const auto coarse_start = Clock::now();
      ++s.counters.coarse_passes;
      const bool kept = s.coarse_correction(state, targets);
      s.counters.coarse_seconds += seconds_since(coarse_start);
      if (kept) {
        ++s.counters.coarse_accepted;
        s.counters.coarse_decrease += previous - state.step.energy;
        // The secant pairs recorded so far still describe the full level's fixed-point map; only
        // a pair spanning the coarse jump would not (measured: fewer outer iterations than clearing).
        if (!over_passes) anderson.restart();
        backoff = 1;
      } else {
        skip = backoff;
        backoff = std::min(2 * backoff, 16);
      }
    }
    const double before_full = state.step.energy;
    const auto full_start = Clock::now();
    if (over_passes) {
      s.counters.full_iterations += s.options.full_iterations;
      s.full_iteration(state, targets, anderson, start_of_iteration, s.options.full_iterations, false);
    } else {
      for (int k = 0; k < s.options.full_iterations; ++k) {
        ++s.counters.full_iterations;
        if (!s.full_iteration(state, targets, anderson, state.X, 1, true)) break;
      }
    }
    s.counters.full_seconds += seconds_since(full_start);
    s.counters.full_decrease += before_full - state.step.energy;
    // Anderson's secant pairs stay valid for the map; only the pair spanning the jump would not
    // (the whole iteration's pairs span none: the next one starts where the path search ends).
    const double before_path = state.step.energy;
    const auto path_start = Clock::now();
    const bool path_moved = s.options.path_extrapolation && it % period == 0 && s.extrapolate_path(state, targets);
    if (path_moved && !over_passes) anderson.restart();
    s.counters.path_seconds += seconds_since(path_start);
    s.counters.path_decrease += before_path - state.step.energy;
    ++s.counters.outer_iterations;
    result.iterations = it;
    result.energy.push_back(state.step.energy);
    result.seconds = seconds_since(start);
    if (options.progress) options.progress(it, state.step.energy, result.seconds);
    if (previous <= 0 || (previous - state.step.energy) / previous < options.tolerance) {
      result.converged = true;
      break;
    }
  }
  result.seconds = seconds_since(start);
  result.counters = s.counters.since(counted_before);
  return result;
}

double HierarchicalSolver::energy(const Eigen::MatrixXd& X, const Eigen::MatrixXd& targets) const {
  return impl_->full->energy(X, impl_->soft_targets(targets));
}

void HierarchicalSolver::anchor_preview(const Eigen::MatrixXd& X, const Eigen::MatrixXd& targets, int level) {
  Impl& s = *impl_;
  if (X.rows() != s.num_vertices() || X.cols() != 3)
    throw InputError("HierarchicalSolver::anchor_preview: X must be 2n x 3");
  if (targets.rows() != static_cast<Eigen::Index>(s.constraints.vertices.size()) || targets.cols() != 3)
    throw InputError("HierarchicalSolver::anchor_preview: one target row per constrained vertex");
  const int L = static_cast<int>(s.reduced.size());
  if (L == 0) throw InputError("HierarchicalSolver::anchor_preview: the solver has no reduced level");
  if (level < -1 || level >= L) throw InputError("HierarchicalSolver::anchor_preview: no reduced level " + std::to_string(level));
  Impl::Preview& p = s.preview;
  p.level = level < 0 ? L - 1 : level;
  p.anchor = X;
  s.set_hard_rows(p.anchor, targets);
  LocalStep step;
  s.full->local_step(p.anchor, step, s.soft_targets(targets));
  const Eigen::MatrixXd gradient = s.full->half_gradient(p.anchor, step, s.soft_targets(targets));
  ReducedLevel& r = s.reduced[p.level];
  r.fit(p.anchor);
  r.local(p.cache);
  p.z_anchor = r.parameters();
  p.z_last.resize(0, 0);
  // As the coarse passes' residual coupling: the level's gradient at the fit equals the full one.
  p.tau = r.half_gradient(targets, p.cache) - r.restrict_field(gradient);
  s.reduced_cache[p.level].energy_valid = false; // its parameters are the preview's now
}

void HierarchicalSolver::preview(Eigen::MatrixXd& X, const Eigen::MatrixXd& targets, int iterations, double extrapolate) {
  Impl& s = *impl_;
  Impl::Preview& p = s.preview;
  if (p.level < 0) throw std::logic_error("HierarchicalSolver::preview before anchor_preview");
  if (iterations < 1) throw InputError("HierarchicalSolver::preview: iterations must be >= 1");
  if (targets.rows() != static_cast<Eigen::Index>(s.constraints.vertices.size()) || targets.cols() != 3)
    throw InputError("HierarchicalSolver::preview: one target row per constrained vertex");
  ReducedLevel& r = s.reduced[p.level];
  if (p.z_last.size() == r.parameters().size() && extrapolate > 0 && extrapolate <= 2) {
    const Eigen::MatrixXd z = r.parameters();
    r.parameters() += extrapolate * (z - p.z_last);
    p.z_last = z;
    r.local(p.cache, false);
  } else {
    p.z_last = r.parameters();
  }
  AndersonHistory anderson(s.options.level_anderson_history);
  Eigen::MatrixXd before, accelerated;
  for (int k = 0; k < iterations; ++k) {
    const Eigen::MatrixXd rhs = r.rhs(targets, p.cache) + p.tau;
    before = r.parameters();
    r.solve(rhs);
    extrapolate_parameters(anderson, r, before, accelerated);
    r.local(p.cache, false);
  }
  s.reduced_cache[p.level].energy_valid = false;
  X = p.anchor + r.positions(r.parameters() - p.z_anchor); // B is linear in z
  s.set_hard_rows(X, targets);
}

void HierarchicalSolver::reset() {
  for (auto& level : impl_->reduced) level.reset();
  for (auto& cache : impl_->reduced_cache) cache.energy_valid = false;
}

int HierarchicalSolver::num_levels() const { return static_cast<int>(impl_->reduced.size()) + 1; }
const ClusterTree& HierarchicalSolver::tree() const { return impl_->tree; }
int HierarchicalSolver::tree_depth(int level) const { return impl_->depth_of_level.at(level); }
int HierarchicalSolver::num_clusters(int level) const { return impl_->reduced.at(level).num_clusters(); }
Eigen::MatrixXd HierarchicalSolver::level_positions(int level) const { return impl_->reduced.at(level).positions(); }
const ClusterWeights& HierarchicalSolver::level_weights(int level) const { return impl_->reduced.at(level).weights(); }
const Eigen::MatrixXd& HierarchicalSolver::level_parameters(int level) const {
  return impl_->reduced.at(level).parameters();
}
double HierarchicalSolver::level_energy(int level, const Eigen::MatrixXd& targets) const {
  LocalCache cache;
  impl_->reduced.at(level).local(cache);
  return cache.elastic + impl_->reduced.at(level).springs(targets);
}
double HierarchicalSolver::factor_seconds() const { return impl_->factor_seconds; }
std::shared_ptr<const ShellSolver> HierarchicalSolver::full_level() const { return impl_->full; }

const HierarchyCounters& HierarchicalSolver::counters() const { return impl_->counters; }

HierarchyCounters HierarchyCounters::since(const HierarchyCounters& earlier) const {
  HierarchyCounters d = *this;
  d.outer_iterations -= earlier.outer_iterations;
  d.full_iterations -= earlier.full_iterations;
  d.coarse_passes -= earlier.coarse_passes;
  d.coarse_accepted -= earlier.coarse_accepted;
  d.rejected_propagations -= earlier.rejected_propagations;
  d.coarse_decrease -= earlier.coarse_decrease;
  d.full_decrease -= earlier.full_decrease;
  d.path_decrease -= earlier.path_decrease;
  d.coarse_seconds -= earlier.coarse_seconds;
  d.full_seconds -= earlier.full_seconds;
  d.path_seconds -= earlier.path_seconds;
  return d;
}

} // namespace gshell
