// The cluster tree and the hierarchical solver (paper §5): partition invariants, subspace
// membership, monotone energy, agreement with the single-level solver.
#include <gshell/deform/handles.h>
#include <gshell/error.h>
#include <gshell/deform/pose.h>
#include <gshell/deform/shell_deformer.h>
#include <gshell/run/pose_run.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/quality/stretch.h>
#include "shell_fixtures.h"
#include <gshell/shell/prism_tets.h>
#include <gshell/solver/cluster_tree.h>
#include <gshell/solver/cluster_weights.h>
#include <gshell/solver/hierarchical_solver.h>
#include <gshell/solver/rest_tets.h>
#include "solver/hierarchy_levels.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <memory>
#include <set>

using namespace gshell;
using gshell::test::offset_shell;

namespace {

/// Hold the rim on one side of a unit bowl, move the rim on the other side by `move`.
HandleSet bowl_pull(const Shell& shell, const Eigen::Vector3d& move) {
  const Eigen::MatrixXd X = shell.vertices();
  Handle hold, pull;
  for (int v = 0; v < X.rows(); ++v) {
    if (X(v, 2) > -0.2 && X(v, 0) < -0.6) hold.vertices.push_back(v);
    if (X(v, 2) > -0.2 && X(v, 0) > 0.6) pull.vertices.push_back(v);
  }
  pull.translate = move;
  HandleSet set;
  set.handles = {hold, pull};
  return set;
}

struct Problem {
  Shell shell;
  Eigen::MatrixXd X;
  RestTets rest;
  PositionConstraints constraints;
  Eigen::MatrixXd targets;
};

Problem bowl_problem(int res, const Eigen::Vector3d& move, bool hard = true) {
  Problem p;
  p.shell = offset_shell(make_bowl(res), 0.06);
  p.X = p.shell.vertices();
  p.rest = rest_tets_from_positions(p.X, build_prism_tets(p.shell.F, p.shell.num_base_vertices()));
  const HandleSet h = bowl_pull(p.shell, move);
  p.constraints.vertices = h.constrained_vertices();
  p.constraints.hard = hard;
  p.constraints.weight = hard ? 0 : 1000 * mean_stiffness(p.rest, static_cast<int>(p.X.rows()));
  p.targets = h.targets(p.X, 1.0);
  return p;
}

/// A solver after `iterations` outer iterations with a coarse pass on every one, so that its
/// reduced levels have left the rest shape.
HierarchicalSolver after_coarse_passes(const Problem& p, HierarchyOptions o, int iterations) {
  o.coarse_period = 1;
  o.first_coarse_iteration = 0;
  HierarchicalSolver solver(p.rest, p.X, p.shell.F, p.constraints, o);
  Eigen::MatrixXd X = p.X;
  SolveOptions so;
  so.max_iterations = iterations;
  solver.solve(X, p.targets, so);
  return solver;
}

/// `iterations` outer iterations from rest, without an early stop; X gets the result.
HierarchicalSolveResult run_from_rest(HierarchicalSolver& solver, const Problem& p, Eigen::MatrixXd& X, int iterations) {
  X = p.X;
  SolveOptions so;
  so.max_iterations = iterations;
  so.tolerance = 0;
  return solver.solve(X, p.targets, so);
}

/// Energy of the minimum a pose solver converges to from rest (relative change < 1e-12).
double converged_energy(const Shell& shell, const HandleSet& handles, PoseSolverKind kind,
                        const HierarchyOptions& options = {}) {
  PoseSolver solver(shell, handles, kind, options);
  Eigen::MatrixXd X = solver.rest_vertices();
  SolveOptions so;
  so.max_iterations = 20000;
  so.tolerance = 1e-12;
  const SolveResult r = solver.solve(X, 1.0, so);
  EXPECT_TRUE(r.converged);
  return solver.energy(X, 1.0);
}

void expect_partition(const ClusterTree& tree, int n) {
  for (int d = 0; d < tree.num_depths(); ++d) {
    ASSERT_EQ(static_cast<int>(tree.cluster_of[d].size()), n);
    const auto members = tree.members(d);
    std::vector<int> seen(n, 0);
    for (const auto& cluster : members) {
      EXPECT_FALSE(cluster.empty()) << "empty cluster at depth " << d;
      for (int v : cluster) ++seen[v];
    }
    for (int v = 0; v < n; ++v) EXPECT_EQ(seen[v], 1) << "vertex " << v << " at depth " << d;
    if (d == 0) continue;
    // Nested: every vertex's cluster lies inside its parent's cluster.
    for (int v = 0; v < n; ++v)
      EXPECT_EQ(tree.parent[d][tree.cluster_of[d][v]], tree.cluster_of[d - 1][v]);
  }
}

void expect_balanced_siblings(const ClusterTree& tree) {
  for (int d = 1; d < tree.num_depths(); ++d) {
    const auto members = tree.members(d);
    std::vector<std::vector<int>> children(tree.num_clusters(d - 1));
    for (int c = 0; c < tree.num_clusters(d); ++c) children[tree.parent[d][c]].push_back(c);
    for (const auto& kids : children) {
      ASSERT_GE(kids.size(), 1u);
      ASSERT_LE(kids.size(), 2u);
      if (kids.size() < 2) continue;
      const double a = static_cast<double>(members[kids[0]].size()), b = static_cast<double>(members[kids[1]].size());
      EXPECT_LE(std::max(a, b), 1.5 * std::min(a, b)) << "depth " << d << ": siblings of " << a << " and " << b;
    }
  }
}

/// The rotation closest to M (independent of the solver's polar decomposition: an SVD).
Eigen::Matrix3d closest_rotation(const Eigen::Matrix3d& M) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU();
  if ((U * svd.matrixV().transpose()).determinant() < 0) U.col(2) *= -1;
  return U * svd.matrixV().transpose();
}

/// Pushes the top vertex over the bowl's bottom (no handle there) below its base: the tets around
/// it invert, as a generated shell's can next to an unextrudable vertex.
void invert_tets_at_the_bottom(Shell& shell) {
  int lowest = 0;
  shell.base.col(2).minCoeff(&lowest);
  shell.top.row(lowest) = shell.base.row(lowest) - 0.5 * (shell.top.row(lowest) - shell.base.row(lowest));
}

} // namespace

TEST(ClusterTree, EveryDepthPartitionsTheVerticesIntoNestedClusters) {
  for (const TriMesh& mesh : {make_bowl(20), make_torus(32), make_plane(24)}) {
    const Shell s = offset_shell(mesh, 0.05);
    ClusterTreeOptions o;
    o.depth = 7;
    o.min_cluster_size = 4;
    const ClusterTree tree = build_cluster_tree(s.vertices(), s.F, o);
    ASSERT_EQ(tree.num_depths(), 8);
    expect_partition(tree, mesh.num_vertices());
    EXPECT_EQ(tree.num_clusters(0), 1);
    EXPECT_GT(tree.num_clusters(7), 110); // nearly every cluster splits each round (2^7 = 128)
  }
}

TEST(ClusterTree, SiblingsHaveNearlyEqualSizes) {
  for (const TriMesh& mesh : {make_bowl(24), make_torus(40), make_cylinder(32)}) {
    const Shell s = offset_shell(mesh, 0.05);
    ClusterTreeOptions o;
    o.depth = 6;
    expect_balanced_siblings(build_cluster_tree(s.vertices(), s.F, o));
  }
}

TEST(ClusterTree, ClustersStopSplittingAtTheMinimumSize) {
  const Shell s = offset_shell(make_bowl(6), 0.05);
  ClusterTreeOptions o;
  o.depth = 10;
  o.min_cluster_size = 10;
  const ClusterTree tree = build_cluster_tree(s.vertices(), s.F, o);
  expect_partition(tree, s.num_base_vertices());
  for (const auto& cluster : tree.members(10)) EXPECT_GE(cluster.size(), 10u);
}

TEST(ClusterTree, HalvesAreSplitAlongTheLongestAxis) {
  // A long strip: the first cut is across its length, at the median.
  const TriMesh plane = make_plane(20);
  Shell s = offset_shell(plane, 0.05);
  s.base.col(0) *= 5.0;
  s.top.col(0) *= 5.0;
  ClusterTreeOptions o;
  o.depth = 1;
  const ClusterTree tree = build_cluster_tree(s.vertices(), s.F, o);
  const auto halves = tree.members(1);
  ASSERT_EQ(halves.size(), 2u);
  double max_a = -1e9, min_b = 1e9;
  const bool a_is_left = s.base(halves[0][0], 0) < 0;
  for (int v : halves[a_is_left ? 0 : 1]) max_a = std::max(max_a, s.base(v, 0));
  for (int v : halves[a_is_left ? 1 : 0]) min_b = std::min(min_b, s.base(v, 0));
  EXPECT_LE(max_a, min_b);
}

TEST(HierarchicalSolver, ReducedLevelsAreExactMembersOfTheirSubspaces) {
  Problem p = bowl_problem(12, {0.5, 0.1, 0.3});
  for (bool residual : {true, false}) {
    HierarchyOptions o;
    o.residual_correction = residual;
    const HierarchicalSolver solver = after_coarse_passes(p, o, 6);
    ASSERT_EQ(solver.num_levels(), 5);
    const int n = p.shell.num_base_vertices();
    for (int l = 0; l + 1 < solver.num_levels(); ++l) {
      const Eigen::MatrixXd Y = solver.level_positions(l);
      const auto members = solver.tree().members(solver.tree_depth(l));
      ASSERT_EQ(static_cast<int>(members.size()), solver.num_clusters(l));
      double worst = 0;
      bool moved = false;
      for (const auto& cluster : members) {
        // Independent check: least-squares affine fit of the level's positions to the rest
        // positions over the cluster's base and top vertices leaves no residual.
        Eigen::MatrixXd U(2 * cluster.size(), 4), P(2 * cluster.size(), 3);
        int r = 0;
        for (int i : cluster)
          for (int v : {i, n + i}) {
            U.row(r) << p.X.row(v), 1.0;
            P.row(r++) = Y.row(v);
          }
        const Eigen::MatrixXd A = U.colPivHouseholderQr().solve(P);
        worst = std::max(worst, (U * A - P).cwiseAbs().maxCoeff());
        moved = moved || (P - U.leftCols(3)).cwiseAbs().maxCoeff() > 1e-3;
      }
      EXPECT_LT(worst, 1e-10) << "level " << l;
      EXPECT_TRUE(moved) << "level " << l << " never left the rest shape";
    }
  }
}

TEST(HierarchicalSolver, LevelsHangFromAFixedCoarsestClusterCountAtEveryMeshSize) {
  // The coarsest reduced level has about coarsest_clusters clusters whatever the resolution, each
  // finer one up to 4x as many; on a small mesh the finest keeps >= finest_cluster_size base
  // vertices per cluster and the levels move up the tree.
  for (int res : {40, 80}) {
    Problem p = bowl_problem(res, {0.8, 0.2, 0.5});
    const int n = p.shell.num_base_vertices();
    HierarchicalSolver solver(p.rest, p.X, p.shell.F, p.constraints);
    ASSERT_EQ(solver.num_levels(), 5) << "res " << res;
    EXPECT_EQ(solver.tree_depth(0), 3) << "res " << res << ", " << n << " base vertices";
    EXPECT_EQ(solver.num_clusters(0), 8) << "res " << res;
    for (int l = 1; l < 4; ++l) {
      EXPECT_EQ(solver.tree_depth(l), solver.tree_depth(l - 1) + 2) << "res " << res << ", level " << l;
      EXPECT_GT(solver.num_clusters(l), 3 * solver.num_clusters(l - 1)) << "res " << res << ", level " << l;
      EXPECT_LE(solver.num_clusters(l), 4 * solver.num_clusters(l - 1)) << "res " << res << ", level " << l;
    }
  }
  Problem small = bowl_problem(12, {0.8, 0.2, 0.5});
  const int n = small.shell.num_base_vertices();
  HierarchicalSolver solver(small.rest, small.X, small.shell.F, small.constraints);
  const int finest = solver.num_levels() - 2;
  EXPECT_EQ(solver.tree_depth(finest), static_cast<int>(std::lround(std::log2(n / 8.0)))) << n << " base vertices";
  EXPECT_LT(solver.tree_depth(0), 3) << "the levels move up on a small mesh";
  // More levels than the mesh can hold: the ones that would repeat a subspace are not built.
  HierarchyOptions many;
  many.levels = 40;
  const HierarchicalSolver deep(small.rest, small.X, small.shell.F, small.constraints, many);
  EXPECT_LT(deep.num_levels(), 8) << n << " base vertices";
  for (int l = 1; l + 1 < deep.num_levels(); ++l) EXPECT_GT(deep.num_clusters(l), deep.num_clusters(l - 1)) << "level " << l;
}

// The stiffness matrix the reduced levels are built from, against a dense sum of every tet's own
// matrix vol G G^T (G from the tet's rest positions, not from the solver's rest shapes): the
// same entries, symmetric, constants in its null space; mean_stiffness is its mean diagonal.
TEST(HierarchicalSolver, StiffnessMatrixIsTheSumOfItsTetsMatrices) {
  const Problem p = bowl_problem(6, {0.3, 0, 0});
  const int N = static_cast<int>(p.X.rows());
  const Eigen::SparseMatrix<double> L = detail::stiffness_matrix(p.rest, N);
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(N, N);
  for (int t = 0; t < p.rest.size(); ++t) {
    Eigen::Matrix3d D;
    for (int k = 0; k < 3; ++k) D.col(k) = (p.X.row(p.rest.T(t, k + 1)) - p.X.row(p.rest.T(t, 0))).transpose();
    const Eigen::Matrix3d Dinv = D.inverse();
    Eigen::Matrix<double, 4, 3> G;
    G.row(0) = -Dinv.colwise().sum();
    G.bottomRows(3) = Dinv;
    const Eigen::Matrix4d K = std::abs(D.determinant()) / 6 * G * G.transpose();
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) dense(p.rest.T(t, a), p.rest.T(t, b)) += K(a, b);
  }
  const Eigen::MatrixXd assembled = Eigen::MatrixXd(L);
  EXPECT_LE((assembled - dense).cwiseAbs().maxCoeff(), 1e-12 * dense.cwiseAbs().maxCoeff());
  EXPECT_LE((assembled - assembled.transpose()).cwiseAbs().maxCoeff(), 1e-14 * dense.cwiseAbs().maxCoeff());
  EXPECT_LE((L * Eigen::VectorXd::Ones(N)).cwiseAbs().maxCoeff(), 1e-12 * dense.cwiseAbs().maxCoeff());
  // Stored entries are the pairs that share a tet, and only those.
  int pairs = 0;
  for (int r = 0; r < N; ++r)
    for (int c = 0; c < N; ++c) pairs += dense(r, c) != 0;
  EXPECT_EQ(L.nonZeros(), pairs);
  EXPECT_NEAR(mean_stiffness(p.rest, N), assembled.diagonal().mean(), 1e-12 * assembled.diagonal().mean());
  // And to the bit the matrix of 16 triplets per tet (how it was assembled before).
  std::vector<Eigen::Triplet<double>> triplets;
  for (int t = 0; t < p.rest.size(); ++t) {
    const Eigen::Matrix<double, 4, 3> G = detail::gradient_rows(p.rest.dm_inv(t));
    const Eigen::Matrix4d K = p.rest.volume(t) * G * G.transpose();
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) triplets.emplace_back(p.rest.T(t, a), p.rest.T(t, b), K(a, b));
  }
  Eigen::SparseMatrix<double> from_triplets(N, N);
  from_triplets.setFromTriplets(triplets.begin(), triplets.end());
  EXPECT_EQ(Eigen::MatrixXd(from_triplets), assembled);
}

// A solver sharing its rest tets solves as one holding a copy, to the bit; a null one is an input error.
TEST(HierarchicalSolver, SharedRestTetsSolveAsACopy) {
  const Problem p = bowl_problem(8, {0.5, 0.1, 0.3});
  HierarchicalSolver copied(p.rest, p.X, p.shell.F, p.constraints);
  HierarchicalSolver shared(std::make_shared<const RestTets>(p.rest), p.X, p.shell.F, p.constraints);
  Eigen::MatrixXd A, B;
  const auto ra = run_from_rest(copied, p, A, 20);
  const auto rb = run_from_rest(shared, p, B, 20);
  EXPECT_EQ(ra.energy, rb.energy);
  EXPECT_EQ(A, B);
  EXPECT_THROW(HierarchicalSolver(std::shared_ptr<const RestTets>(), p.X, p.shell.F, p.constraints), InputError);
}

TEST(HierarchicalSolver, AMeshScaledByAPowerOfTwoIsPosedExactlyScaled) {
  // Every quantity scales exactly by 1024, so the iterates must too. The levels' Anderson used to
  // weigh unitless map rows against translations in model units, and took another path.
  const Problem p = bowl_problem(8, {0.5, 0.1, 0.3});
  Problem scaled = p;
  const double s = 1024;
  scaled.shell.base *= s;
  scaled.shell.top *= s;
  scaled.X *= s;
  scaled.targets *= s;
  scaled.rest = rest_tets_from_positions(scaled.X, build_prism_tets(p.shell.F, p.shell.num_base_vertices()));
  HierarchyOptions o;
  o.first_coarse_iteration = 0;
  ASSERT_GT(o.level_anderson_history, 0);
  HierarchicalSolver solver(p.rest, p.X, p.shell.F, p.constraints, o);
  HierarchicalSolver scaled_solver(scaled.rest, scaled.X, p.shell.F, scaled.constraints, o);
  Eigen::MatrixXd A, B;
  const auto ra = run_from_rest(solver, p, A, 30);
  const auto rb = run_from_rest(scaled_solver, scaled, B, 30);
  EXPECT_GT(ra.counters.coarse_accepted, 0) << "no coarse pass kept: nothing tested";
  EXPECT_EQ(ra.counters.coarse_accepted, rb.counters.coarse_accepted);
  EXPECT_EQ(s * A, B);
}

TEST(HierarchicalSolver, EnergyNeverIncreasesAcrossOuterIterations) {
  Problem p = bowl_problem(12, {0.8, 0.2, 0.5});
  // 0: residual coupling, 1: paper coupling, 2: the defaults, 3: exact border-tet rotations.
  for (int variant = 0; variant < 4; ++variant) {
    const bool defaults = variant == 2;
    HierarchyOptions o;
    o.residual_correction = variant != 1;
    o.anderson_history = defaults ? 5 : 0;
    o.level_anderson_history = defaults ? 5 : 0;
    o.coarse_period = defaults ? HierarchyOptions{}.coarse_period : 1; // else a coarse pass every time
    o.cluster_rotations = variant != 3;
    HierarchicalSolver solver(p.rest, p.X, p.shell.F, p.constraints, o);
    Eigen::MatrixXd X;
    const auto r = run_from_rest(solver, p, X, 60);
    ASSERT_GE(r.energy.size(), 2u);
    for (size_t k = 1; k < r.energy.size(); ++k)
      EXPECT_LE(r.energy[k], r.energy[k - 1]) << "variant " << variant << ", outer iteration " << k;
    EXPECT_LT(r.energy.back(), 0.5 * r.energy.front());
    EXPECT_NEAR(solver.energy(X, p.targets), r.energy.back(), 1e-12 * r.energy.back());
  }
}

TEST(ClusterWeights, PiecewiseWeightsAreAPartitionOfUnityThatReproducesAffineMotions) {
  const Problem p = bowl_problem(12, {0.5, 0.1, 0.3});
  const int n = p.shell.num_base_vertices();
  ClusterTreeOptions to;
  to.depth = 5;
  const ClusterTree tree = build_cluster_tree(p.X, p.shell.F, to);
  const int d = tree.num_depths() - 1;
  // An arbitrary affine motion x = A u + b (not a rotation: stretch and shear included).
  Eigen::Matrix3d A;
  A << 1.3, 0.2, -0.4, 0.1, 0.7, 0.3, -0.2, 0.5, 1.1;
  const Eigen::RowVector3d b(0.3, -1.2, 0.7);
  const Eigen::MatrixXd expected = (p.X * A.transpose()).rowwise() + b;
  {
    const ClusterWeights w = piecewise_cluster_weights(tree.cluster_of[d], tree.num_clusters(d));
    ASSERT_EQ(w.num_vertices(), n);
    for (int i = 0; i < n; ++i) {
      ASSERT_EQ(w.start[i + 1] - w.start[i], 1) << "vertex " << i;
      EXPECT_EQ(w.at(i, tree.cluster_of[d][i]), 1.0) << "a vertex follows its own cluster alone";
    }
    // Every cluster carries the same motion: M_j = A, t_j = A c_j + b (its centroid's image).
    const Eigen::MatrixXd c = cluster_centroids(w, p.X);
    Eigen::MatrixXd Z(4 * w.num_clusters, 3);
    for (int j = 0; j < w.num_clusters; ++j) {
      Z.block(4 * j, 0, 3, 3) = A.transpose();
      Z.row(4 * j + 3) = c.row(j) * A.transpose() + b;
    }
    const Eigen::MatrixXd X = prolongation_matrix(w, p.X, c) * Z;
    EXPECT_LT((X - expected).cwiseAbs().maxCoeff(), 1e-12);
  }
}

TEST(HierarchicalSolver, EnergyNeverRisesAcrossAcceptedCoarseCorrections) {
  // Outer iterations of coarse passes alone (no full-level iterations, no path search): every
  // change of the energy is a coarse correction, and the accepted ones lower it.
  Problem p = bowl_problem(12, {0.8, 0.2, 0.5});
  for (int coarsest : {2, 8}) {
    HierarchyOptions o;
    o.coarsest_clusters = coarsest;
    o.coarse_period = 1;
    o.full_iterations = 0;
    o.path_extrapolation = false;
    HierarchicalSolver solver(p.rest, p.X, p.shell.F, p.constraints, o);
    Eigen::MatrixXd X;
    const auto r = run_from_rest(solver, p, X, 30);
    EXPECT_GT(r.counters.coarse_accepted, 3) << "coarsest " << coarsest;
    int lowered = 0;
    for (size_t k = 1; k < r.energy.size(); ++k) {
      EXPECT_LE(r.energy[k], r.energy[k - 1]) << "coarsest " << coarsest << ", pass " << k;
      lowered += r.energy[k] < r.energy[k - 1];
    }
    EXPECT_EQ(lowered, r.counters.coarse_accepted) << "coarsest " << coarsest;
    EXPECT_NEAR(r.counters.coarse_decrease, r.energy.front() - r.energy.back(), 1e-12 * r.energy.front());
  }
}

TEST(HierarchicalSolver, NoCoarsePassBeforeTheFirstCoarseIteration) {
  // The full level alone decides how the shell starts to buckle: outer iterations before
  // first_coarse_iteration (counted per solve) run no coarse pass, later ones do.
  Problem p = bowl_problem(12, {0.8, 0.2, 0.5});
  for (int first : {0, 7}) {
    HierarchyOptions o;
    o.coarse_period = 1;
    o.first_coarse_iteration = first;
    HierarchicalSolver solver(p.rest, p.X, p.shell.F, p.constraints, o);
    Eigen::MatrixXd X;
    const auto early = run_from_rest(solver, p, X, 6);
    if (first == 0) EXPECT_GT(early.counters.coarse_passes, 0);
    else EXPECT_EQ(early.counters.coarse_passes, 0);
    const auto later = run_from_rest(solver, p, X, 9); // a new solve: iterations 1..9 again
    EXPECT_GT(later.counters.coarse_passes, 0) << "first " << first;
    EXPECT_LE(later.counters.coarse_passes, first == 0 ? 9 : 3) << "first " << first;
  }
}

TEST(HierarchicalSolver, LevelsFromCoarseOrFineTopsReachTheSingleLevelMinimum) {
  const Shell shell = offset_shell(make_bowl(8), 0.08);
  const HandleSet handles = bowl_pull(shell, {0.3, 0.0, 0.15});
  const double single = converged_energy(shell, handles, PoseSolverKind::Single);
  EXPECT_GT(single, 0);
  for (int coarsest : {1, 2, 8, 32}) {
    HierarchyOptions o;
    o.coarsest_clusters = coarsest;
    EXPECT_NEAR(converged_energy(shell, handles, PoseSolverKind::Hierarchical, o), single, 1e-4 * single)
        << "coarsest level of " << coarsest << " clusters";
  }
}

TEST(HierarchicalSolver, AndersonOverWholeIterationsKeepsTheEnergyFallingToTheSameMinimum) {
  // Anderson over whole outer iterations (coarse pass + full iteration) or over the full level's
  // iterations alone: the energy never rises along either, and both reach the single-level minimum.
  const Shell shell = offset_shell(make_bowl(8), 0.08);
  const HandleSet handles = bowl_pull(shell, {0.3, 0.0, 0.15});
  const double single = converged_energy(shell, handles, PoseSolverKind::Single);
  Problem p = bowl_problem(12, {0.8, 0.2, 0.5});
  for (bool over_passes : {true, false}) {
    HierarchyOptions o;
    o.anderson_over_passes = over_passes;
    o.coarse_period = over_passes ? 1 : 2;
    EXPECT_NEAR(converged_energy(shell, handles, PoseSolverKind::Hierarchical, o), single, 1e-4 * single)
        << "over passes " << over_passes;
    HierarchicalSolver solver(p.rest, p.X, p.shell.F, p.constraints, o);
    Eigen::MatrixXd X;
    const auto r = run_from_rest(solver, p, X, 60);
    EXPECT_GT(r.counters.coarse_accepted, 3) << "over passes " << over_passes;
    for (size_t k = 1; k < r.energy.size(); ++k)
      EXPECT_LE(r.energy[k], r.energy[k - 1]) << "over passes " << over_passes << ", outer iteration " << k;
    EXPECT_NEAR(solver.energy(X, p.targets), r.energy.back(), 1e-12 * r.energy.back());
  }
}

TEST(HierarchicalSolver, ClusterRotationEnergyIsTheOwnersBestRotationFit) {
  // With cluster rotations a reduced level's energy is sum_t vol ||F_t - R_j(t)||^2 + springs,
  // j(t) = the cluster of the tet's corner 0 and R_j the rotation closest to sum_{t in j} vol F_t.
  // Recomputed here from the level's positions, tet by tet (soft constraints: known weight).
  Problem p = bowl_problem(10, {0.5, 0.1, 0.3}, /*hard=*/false);
  const HierarchicalSolver solver = after_coarse_passes(p, {}, 3);
  const int n = p.shell.num_base_vertices();
  for (int l = 0; l + 1 < solver.num_levels(); ++l) {
    const Eigen::MatrixXd Y = solver.level_positions(l);
    const std::vector<int>& cluster = solver.tree().cluster_of[solver.tree_depth(l)];
    std::vector<Eigen::Matrix3d> F(p.rest.size()), S(solver.num_clusters(l), Eigen::Matrix3d::Zero());
    for (int t = 0; t < p.rest.size(); ++t) {
      Eigen::Matrix3d D;
      for (int k = 0; k < 3; ++k) D.col(k) = (Y.row(p.rest.T(t, k + 1)) - Y.row(p.rest.T(t, 0))).transpose();
      F[t] = D * p.rest.Dm_inv[t];
      S[cluster[p.rest.T(t, 0) % n]] += p.rest.volume(t) * F[t];
    }
    std::vector<Eigen::Matrix3d> R(S.size());
    for (size_t j = 0; j < S.size(); ++j) R[j] = closest_rotation(S[j]);
    double expected = 0;
    for (int t = 0; t < p.rest.size(); ++t)
      expected += p.rest.volume(t) * (F[t] - R[cluster[p.rest.T(t, 0) % n]]).squaredNorm();
    for (size_t r = 0; r < p.constraints.vertices.size(); ++r)
      expected += p.constraints.weight * (Y.row(p.constraints.vertices[r]) - p.targets.row(r)).squaredNorm();
    EXPECT_NEAR(solver.level_energy(l, p.targets), expected, 1e-9 * expected) << "level " << l;
  }
}

TEST(HierarchicalSolver, HardHandlesSitExactlyOnTheirTargets) {
  Problem p = bowl_problem(10, {0.4, 0.0, 0.2});
  HierarchicalSolver solver(p.rest, p.X, p.shell.F, p.constraints);
  Eigen::MatrixXd X = p.X;
  solver.solve(X, p.targets);
  for (size_t r = 0; r < p.constraints.vertices.size(); ++r)
    EXPECT_EQ((X.row(p.constraints.vertices[r]) - p.targets.row(r)).norm(), 0.0);
}

TEST(HierarchicalSolver, StateCarriesOverBetweenSolves) {
  // A drag: each step starts from the previous result; the second solve of the same targets
  // starts converged and stops at once.
  Problem p = bowl_problem(10, {0.6, 0.1, 0.3});
  HierarchicalSolver solver(p.rest, p.X, p.shell.F, p.constraints);
  Eigen::MatrixXd X = p.X;
  SolveOptions so;
  so.max_iterations = 400;
  so.tolerance = 1e-9;
  for (int k = 1; k <= 4; ++k) {
    const Eigen::MatrixXd P = p.X(p.constraints.vertices, Eigen::all) + (k / 4.0) * (p.targets - p.X(p.constraints.vertices, Eigen::all));
    solver.solve(X, P, so);
  }
  const double E = solver.energy(X, p.targets);
  so.max_iterations = 3;
  so.tolerance = 1e-6;
  const auto again = solver.solve(X, p.targets, so);
  EXPECT_TRUE(again.converged);
  EXPECT_LE(again.energy.back(), E);
}

TEST(PoseSolvers, BothReachTheSameMinimumOnASmallCase) {
  const Shell shell = offset_shell(make_bowl(8), 0.08);
  const HandleSet handles = bowl_pull(shell, {0.3, 0.0, 0.15});
  const double energies[2] = {converged_energy(shell, handles, PoseSolverKind::Single),
                              converged_energy(shell, handles, PoseSolverKind::Hierarchical)};
  EXPECT_GT(energies[0], 0);
  EXPECT_NEAR(energies[1], energies[0], 1e-3 * energies[0]);
}

TEST(PoseSolvers, RigidHandleMotionGivesARigidResult) {
  const Shell shell = offset_shell(make_bowl(10), 0.06);
  HandleSet handles = bowl_pull(shell, Eigen::Vector3d::Zero());
  // Both handles follow the same rigid motion: rotate 70 degrees about a tilted axis through a
  // common center, then translate.
  for (Handle& h : handles.handles) {
    h.axis = Eigen::Vector3d(1, 2, 3).normalized();
    h.degrees = 70;
    h.center = Eigen::Vector3d(0.2, -0.1, 0.3);
    h.translate = Eigen::Vector3d(0.5, -1.0, 2.0);
  }
  const Eigen::Matrix3d R = Eigen::AngleAxisd(70 * M_PI / 180, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  for (PoseSolverKind kind : {PoseSolverKind::Single, PoseSolverKind::Hierarchical}) {
    PoseSolver solver(shell, handles, kind);
    Eigen::MatrixXd X = solver.rest_vertices();
    SolveOptions so;
    so.max_iterations = 3000;
    so.tolerance = 1e-14;
    solver.solve(X, 1.0, so);
    const StretchStats stats = stretch_stats(solver.rest_tets(), X);
    EXPECT_LT(stats.max, 1e-8) << (kind == PoseSolverKind::Single ? "single" : "hierarchical");
    EXPECT_EQ(stats.inverted, 0);
    double worst = 0;
    for (int v = 0; v < X.rows(); ++v) {
      const Eigen::Vector3d u = solver.rest_vertices().row(v).transpose();
      const Eigen::Vector3d expected = R * (u - handles.handles[0].center) + handles.handles[0].center + handles.handles[0].translate;
      worst = std::max(worst, (X.row(v).transpose() - expected).norm());
    }
    EXPECT_LT(worst, 1e-5);
  }
}

TEST(PoseSolvers, SoftHandlesApproachTheirTargets) {
  const Shell shell = offset_shell(make_bowl(10), 0.06);
  HandleSet handles = bowl_pull(shell, {0.3, 0.0, 0.1});
  handles.mode = ConstraintMode::Soft;
  handles.weight = 1e4;
  for (PoseSolverKind kind : {PoseSolverKind::Single, PoseSolverKind::Hierarchical}) {
    PoseSolver solver(shell, handles, kind);
    Eigen::MatrixXd X = solver.rest_vertices();
    SolveOptions so;
    so.max_iterations = 500;
    so.tolerance = 1e-9;
    solver.solve(X, 1.0, so);
    const Eigen::MatrixXd P = solver.targets(1.0);
    double worst = 0;
    for (size_t r = 0; r < solver.constrained_vertices().size(); ++r)
      worst = std::max(worst, (X.row(solver.constrained_vertices()[r]) - P.row(r)).norm());
    EXPECT_LT(worst, 0.02); // of a 0.32 move
  }
}

TEST(PoseSolvers, DragPredictionContinuesTheMotion) {
  const Shell shell = offset_shell(make_bowl(8), 0.08);
  const HandleSet handles = bowl_pull(shell, {0.3, 0.0, 0.15});
  PoseSolver solver(shell, handles, PoseSolverKind::Hierarchical);
  const Eigen::MatrixXd U = solver.rest_vertices();
  Eigen::MatrixXd D(U.rows(), 3);
  for (int v = 0; v < U.rows(); ++v) D.row(v) << 0.1 * U(v, 2), 0.05, -0.02 * U(v, 0);
  // Half-way at 0.5 after moving by D from 0: the straight continuation to 1.0 is U + 2D.
  const Eigen::MatrixXd X = solver.predict_start(U, 0.0, U + D, 0.5, 1.0);
  const Eigen::MatrixXd P = solver.targets(1.0);
  std::vector<char> handle(U.rows(), 0);
  for (size_t r = 0; r < solver.constrained_vertices().size(); ++r) {
    const int v = solver.constrained_vertices()[r];
    handle[v] = 1;
    EXPECT_EQ((X.row(v) - P.row(r)).norm(), 0.0);
  }
  double worst = 0;
  for (int v = 0; v < U.rows(); ++v)
    if (!handle[v]) worst = std::max(worst, (X.row(v) - U.row(v) - 2 * D.row(v)).norm());
  EXPECT_LT(worst, 1e-12);
  // A reversal or a jump far past the last step keeps the previous state.
  EXPECT_EQ((solver.predict_start(U, 0.0, U + D, 0.5, 0.25) - (U + D)).norm(), 0.0);
  EXPECT_EQ((solver.predict_start(U, 0.4, U + D, 0.5, 1.0) - (U + D)).norm(), 0.0);
}

TEST(PoseSolvers, ExtrapolatedDragReachesTheSameMinimum) {
  const Shell shell = offset_shell(make_bowl(8), 0.08);
  const HandleSet handles = bowl_pull(shell, {0.3, 0.0, 0.15});
  double energies[2];
  for (int k = 0; k < 2; ++k) {
    PoseOptions o;
    o.steps = 4;
    o.extrapolate = k == 1;
    o.solve.max_iterations = 5000;
    o.solve.tolerance = 1e-11;
    const PoseResult r = run_pose(shell, handles, o);
    ASSERT_EQ(r.steps.size(), 4u);
    energies[k] = r.steps.back().energy;
  }
  EXPECT_GT(energies[0], 0);
  EXPECT_NEAR(energies[1], energies[0], 1e-3 * energies[0]);
}

// The rest check and the cluster tree read rest_vertices through the tets' and faces' ids, so a
// too-short or too-narrow matrix must be refused before either runs.
TEST(HierarchicalSolver, RestVerticesThatTheTetsOrFacesOverrunAreInputErrors) {
  const Problem p = bowl_problem(6, {0.2, 0, 0});
  const Eigen::MatrixXd too_few = p.X.topRows(p.X.rows() - 2);
  EXPECT_THROW(HierarchicalSolver(p.rest, too_few, p.shell.F, p.constraints), InputError);
  const Eigen::MatrixXd two_columns = p.X.leftCols(2);
  EXPECT_THROW(HierarchicalSolver(p.rest, two_columns, p.shell.F, p.constraints), InputError);
  Eigen::MatrixXi F = p.shell.F;
  F(0, 0) = p.shell.num_base_vertices();
  EXPECT_THROW(HierarchicalSolver(p.rest, p.X, F, p.constraints), InputError);
  EXPECT_NO_THROW(HierarchicalSolver(p.rest, p.X, p.shell.F, p.constraints));
}

// A generated shell can hold a few inverted tets (next to unextrudable vertices or base crossings):
// pose takes the deformer's rest shapes, where those tets take their ideal prism's shape, so such a
// shell can be posed, every solver reaches the same minimum, and at rest the inversion is undone.
TEST(PoseSolvers, AShellWithInvertedTetsIsPosedFromTheirIdealShapes) {
  Shell shell = offset_shell(make_bowl(8), 0.08);
  invert_tets_at_the_bottom(shell);
  int replaced = 0;
  deformation_rest_tets(shell, &replaced);
  ASSERT_GT(replaced, 0);
  EXPECT_THROW(rest_tets_from_positions(shell.vertices(), build_prism_tets(shell.F, shell.num_base_vertices())),
               InputError); // what pose used to build, and refused such shells with

  const HandleSet handles = bowl_pull(shell, {0.3, 0.0, 0.15});
  HierarchyOptions exact;
  exact.cluster_rotations = false; // the levels' exact energy: the replaced tets become border tets
  const double single = converged_energy(shell, handles, PoseSolverKind::Single);
  EXPECT_GT(single, 0);
  EXPECT_NEAR(converged_energy(shell, handles, PoseSolverKind::Hierarchical), single, 1e-3 * single);
  EXPECT_NEAR(converged_energy(shell, handles, PoseSolverKind::Hierarchical, exact), single, 1e-3 * single);

  // Handles held where they are: the shell relaxes towards the ideal shapes and the tets come right.
  const HandleSet hold = bowl_pull(shell, Eigen::Vector3d::Zero());
  for (const HierarchyOptions& options : {HierarchyOptions{}, exact}) {
    PoseSolver solver(shell, hold, PoseSolverKind::Hierarchical, options);
    EXPECT_EQ(solver.rest_tets().override_tets.size(), static_cast<size_t>(replaced));
    Eigen::MatrixXd X = solver.rest_vertices();
    SolveOptions so;
    so.max_iterations = 2000;
    so.tolerance = 1e-10;
    solver.solve(X, 1.0, so);
    const Eigen::MatrixXi T = build_prism_tets(shell.F, shell.num_base_vertices());
    for (Eigen::Index t = 0; t < T.rows(); ++t) {
      Eigen::Matrix3d D;
      for (int k = 0; k < 3; ++k) D.col(k) = (X.row(T(t, k + 1)) - X.row(T(t, 0))).transpose();
      EXPECT_GT(D.determinant(), 0) << "tet " << t;
    }
  }
}

TEST(HierarchicalSolver, ExactLevelEnergyHoldsForTetsWithRestShapesOfTheirOwn) {
  // Without cluster rotations a reduced level's energy is the exact subspace energy
  // sum_t vol ||F_t - R(F_t)||^2 + springs (R: the closest rotation). A tet whose rest shape is not
  // its rest corners' (an inverted tet replaced by its ideal shape) must not be taken for one that
  // moves with its cluster (F = M_j): recomputed here tet by tet from the level's positions.
  Problem p = bowl_problem(10, {0.5, 0.1, 0.3}, /*hard=*/false);
  invert_tets_at_the_bottom(p.shell);
  p.X = p.shell.vertices();
  p.rest = deformation_rest_tets(p.shell);
  ASSERT_FALSE(p.rest.override_tets.empty());
  HierarchyOptions o;
  o.cluster_rotations = false;
  const HierarchicalSolver solver = after_coarse_passes(p, o, 3);
  for (int l = 0; l + 1 < solver.num_levels(); ++l) {
    const Eigen::MatrixXd Y = solver.level_positions(l);
    double expected = 0;
    for (int t = 0; t < p.rest.size(); ++t) {
      Eigen::Matrix3d D;
      for (int k = 0; k < 3; ++k) D.col(k) = (Y.row(p.rest.T(t, k + 1)) - Y.row(p.rest.T(t, 0))).transpose();
      const Eigen::Matrix3d F = D * p.rest.dm_inv(t);
      expected += p.rest.volume(t) * (F - closest_rotation(F)).squaredNorm();
    }
    for (size_t r = 0; r < p.constraints.vertices.size(); ++r)
      expected += p.constraints.weight * (Y.row(p.constraints.vertices[r]) - p.targets.row(r)).squaredNorm();
    EXPECT_NEAR(solver.level_energy(l, p.targets), expected, 1e-9 * expected) << "level " << l;
  }
}

TEST(HierarchicalSolver, AFlatRestShellBuildsNoReducedLevelAndSolvesAsTheFullLevel) {
  // Top = base: the rest tets are the faces' normal prisms (deformation_rest_tets), but the rest
  // positions the clusters' affine maps are fitted to lie in one plane, so no map is determined.
  // That gave "reduced matrix is not positive definite"; now the full level solves alone.
  Shell flat = offset_shell(make_plane(8), 0.1);
  flat.top = flat.base;
  const Eigen::MatrixXd X0 = flat.vertices();
  const int n = flat.num_base_vertices();
  PositionConstraints constraints;
  constraints.hard = true;
  Eigen::MatrixXd targets(2, 3);
  constraints.vertices = {0, n - 1};
  targets << X0.row(0), X0.row(n - 1) + Eigen::RowVector3d(0, 0, 0.3);
  const ClusterTree tree = build_cluster_tree(X0, flat.F);
  EXPECT_FALSE(tree.spans_3d);
  HierarchicalSolver solver(deformation_rest_tets(flat), X0, flat.F, constraints);
  EXPECT_EQ(solver.num_levels(), 1);
  Eigen::MatrixXd X = X0;
  SolveOptions options;
  options.max_iterations = 20;
  solver.solve(X, targets, options);
  EXPECT_LT((X.row(n - 1) - targets.row(1)).norm(), 1e-9);
  EXPECT_GT(X(n / 2, 2), 0.0); // the middle follows the pulled corner up
  // A shell with thickness spans 3D at its root.
  EXPECT_TRUE(build_cluster_tree(offset_shell(make_plane(8), 0.1).vertices(), flat.F).spans_3d);
}
