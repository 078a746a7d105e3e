// Local/global solver: monotone energy, exact fixed vertices, soft constraints, rigid invariance.
#include <gshell/error.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/solver/shell_solver.h>

#include "core_test_meshes.h"
#include "shell_fixtures.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <thread>

#include <sys/wait.h>
#include <unistd.h>

using namespace gshell;
using gshell::test::SimpleMesh;
using gshell::test::vertex_range;

namespace {

// A generation problem: normal prisms as rest shapes, base fixed, start = offset top.
struct Generation {
  RestTets rest;
  Eigen::MatrixXd X;
  int n;
};

Generation generation(const SimpleMesh& m, double eta) {
  Generation g;
  g.n = static_cast<int>(m.V.rows());
  g.rest = prism_rest_tets(m.F, g.n, normal_prisms(m.V, m.F, eta));
  g.X.resize(2 * g.n, 3);
  g.X << m.V, offset_top(m.V, m.F, eta);
  return g;
}

// Exactly k iterations (no stop on tolerance), so that two solvers' energies compare step by step.
SolveOptions exactly(int k) {
  SolveOptions o;
  o.max_iterations = k;
  o.tolerance = 0;
  return o;
}

void expect_monotone(const std::vector<double>& E) {
  // Round-off of an energy sum is relative to its largest value, the start energy.
  for (std::size_t k = 1; k < E.size(); ++k) EXPECT_LE(E[k], E[k - 1] + 1e-12 * E[0]) << "iteration " << k;
}

} // namespace

TEST(ShellSolver, EnergyNeverIncreasesAndBaseStaysExact) {
  const std::vector<std::pair<std::string, SimpleMesh>> cases = {
      {"sphere", test::icosphere(3)},
      {"torus", test::torus(40, 16)},
      {"open wavy plane", test::plane(20, 0.3)},
      {"permuted torus", test::permuted(test::torus(30, 12), 3)}};
  for (const auto& [name, m] : cases) {
    for (double eta : {0.02, 0.2}) {
      SCOPED_TRACE(name + " eta " + std::to_string(eta));
      Generation g = generation(m, eta);
      const Eigen::MatrixXd start = g.X;
      const ShellSolver solver(g.rest, 2 * g.n, vertex_range(0, g.n));
      SolveOptions options;
      options.max_iterations = 40;
      options.tolerance = 0;
      int calls = 0;
      options.progress = [&](int, double, double) { ++calls; };
      const SolveResult r = solver.solve(g.X, options);
      EXPECT_EQ(r.iterations, 40);
      EXPECT_EQ(calls, 40);
      ASSERT_EQ(r.energy.size(), 41u);
      expect_monotone(r.energy);
      EXPECT_LT(r.energy.back(), r.energy.front());
      EXPECT_NEAR(r.energy.front(), solver.energy(start), 1e-12 * r.energy.front());
      EXPECT_NEAR(r.energy.back(), solver.energy(g.X), 1e-12 * r.energy.front());
      EXPECT_TRUE(g.X.topRows(g.n) == start.topRows(g.n)) << "fixed base moved";
    }
  }
}

TEST(ShellSolver, StopsOnTolerance) {
  Generation g = generation(test::icosphere(2), 0.05);
  const ShellSolver solver(g.rest, 2 * g.n, vertex_range(0, g.n));
  SolveOptions options;
  options.max_iterations = 500;
  options.tolerance = 1e-4;
  const SolveResult r = solver.solve(g.X, options);
  EXPECT_TRUE(r.converged);
  EXPECT_LT(r.iterations, 500);
  const double last = r.energy[r.energy.size() - 1], before = r.energy[r.energy.size() - 2];
  EXPECT_LT(std::abs(before - last), 1e-4 * before);
  // Zero iterations: only the start energy.
  Eigen::MatrixXd X = g.X;
  options.max_iterations = 0;
  const SolveResult none = solver.solve(X, options);
  EXPECT_EQ(none.iterations, 0);
  EXPECT_EQ(none.energy.size(), 1u);
  EXPECT_TRUE(X == g.X);
}

TEST(ShellSolver, RigidlyMovedBaseCarriesTheTopAlong) {
  // Rest shell = a seamless shell; fixing its base at a rigid motion of itself must give the same
  // rigid motion of the top (zero energy), whatever the start.
  const SimpleMesh m = test::torus(32, 12);
  const int n = static_cast<int>(m.V.rows());
  Eigen::MatrixXd rest_X(2 * n, 3);
  rest_X << m.V, offset_top(m.V, m.F, 0.1);
  const RestTets rest = rest_tets_from_positions(rest_X, build_prism_tets(m.F, n));
  const ShellSolver solver(rest, 2 * n, vertex_range(0, n));
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.3, 1, 0.2).normalized()).toRotationMatrix();
  const Eigen::RowVector3d t(0.5, -1, 2);
  const Eigen::MatrixXd target = (rest_X * R.transpose()).rowwise() + t;
  Eigen::MatrixXd X = rest_X;
  X.topRows(n) = target.topRows(n);
  SolveOptions options;
  options.max_iterations = 300;
  options.tolerance = 1e-14;
  const SolveResult r = solver.solve(X, options);
  expect_monotone(r.energy);
  EXPECT_LT(r.energy.back(), 1e-14 * r.energy.front());
  EXPECT_LT((X - target).cwiseAbs().maxCoeff(), 1e-6);
}

TEST(ShellSolver, SoftConstraintsPullTowardTargets) {
  // No fixed vertices: a few soft handles at a rigid motion of the rest shell determine it.
  const SimpleMesh m = test::icosphere(2);
  const int n = static_cast<int>(m.V.rows());
  Eigen::MatrixXd rest_X(2 * n, 3);
  rest_X << m.V, 1.1 * m.V;
  const RestTets rest = rest_tets_from_positions(rest_X, build_prism_tets(m.F, n));
  SoftConstraints soft;
  soft.vertices = {0, 5, 17, n + 30, n + 77};
  soft.weight = 10.0;
  const ShellSolver solver(rest, 2 * n, {}, soft);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.2, Eigen::Vector3d(1, 0, 0.5).normalized()).toRotationMatrix();
  const Eigen::MatrixXd target = (rest_X * R.transpose()).rowwise() + Eigen::RowVector3d(0.1, 0.2, 0.3);
  Eigen::MatrixXd P(soft.vertices.size(), 3);
  for (std::size_t c = 0; c < soft.vertices.size(); ++c) P.row(c) = target.row(soft.vertices[c]);
  Eigen::MatrixXd X = rest_X;
  SolveOptions options;
  options.max_iterations = 2000;
  options.tolerance = 1e-15;
  const SolveResult r = solver.solve(X, options, P);
  expect_monotone(r.energy);
  EXPECT_NEAR(r.energy.back(), solver.energy(X, P), 1e-12 * r.energy.front());
  EXPECT_LT(r.energy.back(), 1e-8 * r.energy.front());
  EXPECT_LT((X - target).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_THROW(solver.solve(X, options), InputError); // targets are required
  // Non-finite numbers are errors, not NaN shells (a NaN in a fixed row reached every row).
  Eigen::MatrixXd bad = rest_X;
  bad(n + 3, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(solver.solve(bad, options, P), InputError);
  Eigen::MatrixXd bad_targets = P;
  bad_targets(1, 2) = std::numeric_limits<double>::infinity();
  EXPECT_THROW(solver.solve(X, options, bad_targets), InputError);
  // A negative weight is named (it was "the shell system is singular").
  soft.weight = -1;
  try {
    ShellSolver(rest, 2 * n, {}, soft);
    ADD_FAILURE() << "a negative weight was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("weight must be positive and finite (got -1)"), std::string::npos) << e.what();
  }
  // So is a weight of 0, SoftConstraints' default: its springs were dropped, the part left free.
  soft.weight = 0;
  EXPECT_THROW(ShellSolver(rest, 2 * n, {}, soft), InputError);
}

TEST(ShellSolver, AProcessForkedAfterAFactorisationCanFactorToo) {
  // GNU OpenMP's thread pool (CHOLMOD's parallel regions) does not survive fork: a child's first
  // factorisation waited for the parent's pool threads forever (Python's multiprocessing workers).
  const Shell shell = test::sphere_shell(3, 0.05);
  const int n = shell.num_base_vertices();
  std::vector<int> base(n);
  std::iota(base.begin(), base.end(), 0);
  const RestTets rest = normal_prism_rest_tets(shell.base, shell.F, shell.thickness);
  { const ShellSolver parent(rest, 2 * n, base); }
  const pid_t child = fork();
  if (child == 0) {
    alarm(60); // a hang ends as SIGALRM, not as a hung suite
    const ShellSolver again(rest, 2 * n, base);
    Eigen::MatrixXd X = shell.vertices();
    _exit(again.solve(X).energy.empty() ? 1 : 0);
  }
  ASSERT_GT(child, 0);
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
      << (WIFSIGNALED(status) ? "child killed by signal " + std::to_string(WTERMSIG(status)) : "child failed");
}

TEST(ShellSolver, APartHeldByNothingIsSingularOnEveryPath) {
  // Two separate prism layers; only the first one's base is kept. The second part's rows of L_ff
  // are singular, which a factorisation may miss to rounding and CG never tests: the solver named
  // neither and moved the free part anywhere.
  const SimpleMesh a = test::icosphere(2), b = test::icosphere(1);
  const int na = static_cast<int>(a.V.rows()), nb = static_cast<int>(b.V.rows()), n = na + nb;
  const Eigen::RowVector3d apart(5, 5, 5);
  Eigen::MatrixXi F(a.F.rows() + b.F.rows(), 3);
  F << a.F, b.F.array() + na;
  Eigen::MatrixXd X(2 * n, 3); // base, then top: each sphere and 1.1 times it
  X << a.V, b.V.rowwise() + apart, 1.1 * a.V, (1.1 * b.V).rowwise() + apart;
  const RestTets rest = rest_tets_from_positions(X, build_prism_tets(F, n));
  std::vector<int> first_base(na);
  std::iota(first_base.begin(), first_base.end(), 0);
  for (const LinearSolver kind : {LinearSolver::Direct, LinearSolver::ConjugateGradient}) {
    LinearSolverOptions linear;
    linear.kind = kind;
    try {
      ShellSolver(rest, 2 * n, first_base, {}, linear);
      ADD_FAILURE() << "a free part was accepted";
    } catch (const InputError& e) {
      // The part is named by its lowest free vertex: the second sphere's first base vertex.
      EXPECT_NE(std::string(e.what()).find("singular: a connected part of the tets has no fixed or constrained vertex "
                                           "(e.g. the part with vertex " + std::to_string(na) + ")"),
                std::string::npos)
          << e.what();
    }
    // Nothing kept at all: the same.
    EXPECT_THROW(ShellSolver(rest, 2 * n, {}, {}, linear), InputError);
    // One spring on the second part holds it.
    SoftConstraints soft;
    soft.vertices = {na + 3};
    soft.weight = 1;
    EXPECT_NO_THROW(ShellSolver(rest, 2 * n, first_base, soft, linear));
  }
  // A rest volume that is not a positive number is named, not a NaN shell or a "singular" system.
  for (const double volume : {std::numeric_limits<double>::quiet_NaN(), -1.0}) {
    RestTets broken = rest;
    broken.volume[7] = volume;
    std::vector<int> all_base(n);
    std::iota(all_base.begin(), all_base.end(), 0);
    try {
      ShellSolver(broken, 2 * n, all_base);
      ADD_FAILURE() << "volume " << volume << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("rest tet 7 has volume"), std::string::npos) << e.what();
    }
  }
}

TEST(ShellSolver, SoftAndFixedTogether) {
  // Soft pull on a few top vertices of a fixed-base shell: energy still monotone, the pulled
  // vertices move toward their targets, the base does not move.
  Generation g = generation(test::plane(12, 0.1), 0.1);
  SoftConstraints soft;
  soft.vertices = {g.n + 0, g.n + 40, g.n + 100};
  soft.weight = 1.0;
  const ShellSolver solver(g.rest, 2 * g.n, vertex_range(0, g.n), soft);
  Eigen::MatrixXd P(3, 3);
  for (int c = 0; c < 3; ++c) P.row(c) = g.X.row(soft.vertices[c]) + Eigen::RowVector3d(0, 0, 0.05);
  const Eigen::MatrixXd start = g.X;
  SolveOptions options;
  options.max_iterations = 30;
  options.tolerance = 0;
  const SolveResult r = solver.solve(g.X, options, P);
  expect_monotone(r.energy);
  EXPECT_TRUE(g.X.topRows(g.n) == start.topRows(g.n));
  Generation free_run = generation(test::plane(12, 0.1), 0.1);
  const ShellSolver plain(free_run.rest, 2 * free_run.n, vertex_range(0, free_run.n));
  plain.solve(free_run.X, options);
  for (int c = 0; c < 3; ++c) EXPECT_GT(g.X(soft.vertices[c], 2), free_run.X(soft.vertices[c], 2));
}

TEST(ShellSolver, StepsReproduceSolveAndGradientMatchesFiniteDifferences) {
  // Soft pull on the top of a fixed-base plane shell: both the eliminated rows and the springs
  // enter the steps and the gradient.
  Generation g = generation(test::plane(10, 0.2), 0.1);
  SoftConstraints soft;
  soft.vertices = {g.n + 3, g.n + 50};
  soft.weight = 2.0;
  const ShellSolver solver(g.rest, 2 * g.n, vertex_range(0, g.n), soft);
  Eigen::MatrixXd P(2, 3);
  for (int c = 0; c < 2; ++c) P.row(c) = g.X.row(soft.vertices[c]) + Eigen::RowVector3d(0.03, 0, 0.05);

  Eigen::MatrixXd by_solve = g.X, by_steps = g.X;
  SolveOptions options;
  options.max_iterations = 5;
  options.tolerance = 0;
  const SolveResult r = solver.solve(by_solve, options, P);
  LocalStep step;
  solver.local_step(by_steps, step, P);
  EXPECT_DOUBLE_EQ(step.energy, r.energy[0]);
  for (int k = 1; k <= 5; ++k) {
    solver.global_step(by_steps, step, P);
    solver.local_step(by_steps, step, P);
    EXPECT_DOUBLE_EQ(step.energy, r.energy[k]) << "iteration " << k;
  }
  EXPECT_TRUE(by_steps == by_solve);

  // The rotations minimise the energy, so the gradient at fixed rotations is E's gradient.
  const Eigen::MatrixXd g_half = solver.half_gradient(by_steps, step, P);
  EXPECT_TRUE(g_half.topRows(g.n).isZero()) << "kept vertices have no gradient";
  const double h = 1e-6;
  for (int v : {g.n + 3, g.n + 17, g.n + 50, 2 * g.n - 1})
    for (int d = 0; d < 3; ++d) {
      Eigen::MatrixXd plus = by_steps, minus = by_steps;
      plus(v, d) += h;
      minus(v, d) -= h;
      const double fd = (solver.energy(plus, P) - solver.energy(minus, P)) / (2 * h);
      EXPECT_NEAR(2 * g_half(v, d), fd, 1e-6 * std::max(1.0, std::abs(fd))) << "vertex " << v << " axis " << d;
    }
}

TEST(ShellSolver, AssemblyIsTheSumOfTheTetsAndDoesNotDependOnTheThreadCount) {
  // Row j of A = sum over the tets t at free vertex j of vol_t G_t G_t^T (G_t = [-1 -1 -1; I]
  // Dm_inv_t): rebuilt here tet by tet and compared with the solver's rows, built in parallel
  // blocks with one thread and with all of them (same bits).
  const Generation g = generation(gshell::test::icosphere(4), 0.1); // 2,562 free rows: several blocks
  const int n = g.n;
  const std::vector<int> free_rows = vertex_range(n, n);
  using Rows = Eigen::SparseMatrix<double, Eigen::RowMajor>;
  auto rows_with = [&](int threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    const ShellSolver solver(g.rest, 2 * n, vertex_range(0, n));
    return solver.system_rows(free_rows);
  };
  const Rows one = rows_with(1);
  const Rows all = rows_with(static_cast<int>(std::max(2u, std::thread::hardware_concurrency())));
  ASSERT_EQ(one.nonZeros(), all.nonZeros());
  EXPECT_TRUE(std::equal(one.valuePtr(), one.valuePtr() + one.nonZeros(), all.valuePtr()));
  EXPECT_TRUE(std::equal(one.innerIndexPtr(), one.innerIndexPtr() + one.nonZeros(), all.innerIndexPtr()));
  std::vector<Eigen::Triplet<double>> entries;
  Eigen::Matrix<double, 4, 3> E;
  E << -1, -1, -1, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  for (int t = 0; t < g.rest.size(); ++t) {
    const Eigen::Matrix<double, 4, 3> G = E * g.rest.Dm_inv[t];
    const Eigen::Matrix4d local = g.rest.volume[t] * G * G.transpose();
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b)
        if (g.rest.T(t, a) >= n && g.rest.T(t, b) >= n) // free rows, free columns (the base is kept)
          entries.emplace_back(g.rest.T(t, a) - n, g.rest.T(t, b), local(a, b));
  }
  Rows want(n, 2 * n);
  want.setFromTriplets(entries.begin(), entries.end());
  const Rows difference = one - want;
  double worst = 0;
  for (Eigen::Index k = 0; k < difference.nonZeros(); ++k) worst = std::max(worst, std::abs(difference.valuePtr()[k]));
  EXPECT_LT(worst, 1e-12 * want.coeffs().cwiseAbs().maxCoeff());
}

TEST(ShellSolver, UnconstrainedSystemIsRejected) {
  const SimpleMesh m = test::icosphere(1);
  const int n = static_cast<int>(m.V.rows());
  Eigen::MatrixXd X(2 * n, 3);
  X << m.V, 1.1 * m.V;
  const RestTets rest = rest_tets_from_positions(X, build_prism_tets(m.F, n));
  EXPECT_THROW(ShellSolver(rest, 2 * n, {}), InputError);
  EXPECT_THROW(ShellSolver(rest, 2 * n, {2 * n}), InputError);
}

namespace {

LinearSolverOptions linear_solver(LinearSolver kind) {
  LinearSolverOptions o;
  o.kind = kind;
  return o;
}

/// Closed, genus 1 and open meshes for comparing the linear paths and accelerations.
std::vector<std::pair<std::string, SimpleMesh>> linear_solver_cases() {
  return {{"sphere", test::icosphere(3)}, {"torus", test::torus(40, 16)}, {"open wavy plane", test::plane(20, 0.3)}};
}

/// Iterations until the energy stops changing (to the last digits).
SolveOptions to_convergence() {
  SolveOptions o;
  o.max_iterations = 2000;
  o.tolerance = 1e-13;
  return o;
}

} // namespace

TEST(ShellSolver, ConjugateGradientGivesTheDirectShell) {
  // The same iterations solved by a factor and by CG from the current iterate, preconditioned by
  // the diagonal or by the multigrid V-cycle (with a coarsest level small enough for 3-4 levels
  // here), CG run to its absolute tolerance alone: the energies and the tops agree to that
  // tolerance, and CG's energies never rise either.
  const auto cases = linear_solver_cases();
  for (const auto& [name, m] : cases)
    for (double eta : {0.02, 0.2})
    for (CgPreconditioner preconditioner : {CgPreconditioner::Jacobi, CgPreconditioner::Multigrid}) {
      SCOPED_TRACE(name + " eta " + std::to_string(eta) +
                   (preconditioner == CgPreconditioner::Jacobi ? " jacobi" : " multigrid"));
      Generation g = generation(m, eta);
      const ShellSolver direct(g.rest, 2 * g.n, vertex_range(0, g.n), {}, linear_solver(LinearSolver::Direct));
      LinearSolverOptions cg_options = linear_solver(LinearSolver::ConjugateGradient);
      cg_options.preconditioner = preconditioner;
      cg_options.multigrid.coarsest_rows = 20;
      cg_options.cg_relative_tolerance = 0;
      const ShellSolver cg(g.rest, 2 * g.n, vertex_range(0, g.n), {}, cg_options);
      EXPECT_EQ(direct.linear_solver(), LinearSolver::Direct);
      EXPECT_EQ(cg.linear_solver(), LinearSolver::ConjugateGradient);
      const SolveOptions options = exactly(15);
      Eigen::MatrixXd X_direct = g.X, X_cg = g.X;
      const SolveResult r_direct = direct.solve(X_direct, options);
      const SolveResult r_cg = cg.solve(X_cg, options);
      EXPECT_EQ(r_direct.linear_iterations, 0);
      EXPECT_GT(r_cg.linear_iterations, 0);
      expect_monotone(r_cg.energy);
      ASSERT_EQ(r_cg.energy.size(), r_direct.energy.size());
      for (std::size_t k = 0; k < r_cg.energy.size(); ++k)
        EXPECT_NEAR(r_cg.energy[k], r_direct.energy[k], 1e-7 * r_direct.energy[0]) << "iteration " << k;
      EXPECT_LT((X_cg - X_direct).cwiseAbs().maxCoeff(), 1e-6 * eta);
      EXPECT_TRUE(X_cg.topRows(g.n) == g.X.topRows(g.n)) << "fixed base moved";
    }
}

TEST(ShellSolver, ConjugateGradientRenumbersItsRowsWithoutChangingTheShell) {
  // The CG path orders its rows breadth first. On a mesh whose vertex and face orders are
  // shuffled (tets too incoherent for the colouring, so the rotations are gathered by row), with
  // soft springs on three top vertices, it still takes the factor's iterations and gives the
  // factor's steps, gradient and system rows, all in the caller's vertex order.
  const Generation g = generation(test::permuted(test::torus(40, 16), 7), 0.05);
  for (CgPreconditioner preconditioner : {CgPreconditioner::Jacobi, CgPreconditioner::Multigrid}) {
  SCOPED_TRACE(preconditioner == CgPreconditioner::Jacobi ? "jacobi" : "multigrid");
  SoftConstraints soft;
  soft.vertices = {g.n + 3, g.n + 200, 2 * g.n - 1};
  soft.weight = 2.0;
  Eigen::MatrixXd P(3, 3);
  for (int c = 0; c < 3; ++c) P.row(c) = g.X.row(soft.vertices[c]) + Eigen::RowVector3d(0.02, 0, 0.03);
  LinearSolverOptions cg_options = linear_solver(LinearSolver::ConjugateGradient);
  cg_options.preconditioner = preconditioner;
  cg_options.multigrid.coarsest_rows = 20;
  cg_options.cg_relative_tolerance = 0;
  const ShellSolver direct(g.rest, 2 * g.n, vertex_range(0, g.n), soft, linear_solver(LinearSolver::Direct));
  const ShellSolver cg(g.rest, 2 * g.n, vertex_range(0, g.n), soft, cg_options);
  ASSERT_EQ(cg.linear_solver(), LinearSolver::ConjugateGradient);
  std::vector<int> rows = cg.free_vertices();
  EXPECT_NE(rows, direct.free_vertices()) << "the CG rows kept the input's order: nothing tested";
  std::sort(rows.begin(), rows.end());
  EXPECT_EQ(rows, direct.free_vertices());

  const std::vector<int> some = {g.n, g.n + 200, 2 * g.n - 1, g.n + 3};
  EXPECT_LT((Eigen::MatrixXd(cg.system_rows(some)) - Eigen::MatrixXd(direct.system_rows(some))).cwiseAbs().maxCoeff(),
            1e-12 * Eigen::MatrixXd(direct.system_rows(some)).cwiseAbs().maxCoeff());

  Eigen::MatrixXd X_direct = g.X, X_cg = g.X;
  const SolveResult r_direct = direct.solve(X_direct, exactly(10), P);
  const SolveResult r_cg = cg.solve(X_cg, exactly(10), P);
  expect_monotone(r_cg.energy);
  ASSERT_EQ(r_cg.energy.size(), r_direct.energy.size());
  for (std::size_t k = 0; k < r_cg.energy.size(); ++k)
    EXPECT_NEAR(r_cg.energy[k], r_direct.energy[k], 1e-7 * r_direct.energy[0]) << "iteration " << k;
  EXPECT_LT((X_cg - X_direct).cwiseAbs().maxCoeff(), 1e-6 * 0.05);

  LocalStep s_direct, s_cg;
  direct.local_step(g.X, s_direct, P);
  cg.local_step(g.X, s_cg, P);
  const Eigen::MatrixXd gradient = direct.half_gradient(g.X, s_direct, P);
  EXPECT_LT((cg.half_gradient(g.X, s_cg, P) - gradient).cwiseAbs().maxCoeff(), 1e-12 * gradient.cwiseAbs().maxCoeff());
  Eigen::MatrixXd step_direct = g.X, step_cg = g.X;
  direct.global_step(step_direct, s_direct, P);
  cg.global_step(step_cg, s_cg, P);
  EXPECT_LT((step_cg - step_direct).cwiseAbs().maxCoeff(), 1e-6 * 0.05);
  EXPECT_TRUE(step_cg.topRows(g.n) == g.X.topRows(g.n)) << "fixed base moved";
  }
}

TEST(ShellSolver, InexactConjugateGradientStepsReachTheDirectFixedPoint) {
  // CG stopped once each column's residual has fallen to cg_relative_tolerance of its warm
  // start (the default) takes other iterates than the factor, but every one lowers the energy,
  // and run to convergence they end at the same fixed point: the warm start's residual vanishes
  // there. The loosest tolerance (0.5) as well as the default.
  const auto cases = linear_solver_cases();
  for (const auto& [name, m] : cases)
    for (double eta : {0.02, 0.2})
      for (double relative : {LinearSolverOptions{}.cg_relative_tolerance, 0.5}) {
        SCOPED_TRACE(name + " eta " + std::to_string(eta) + " relative " + std::to_string(relative));
        Generation g = generation(m, eta);
        const ShellSolver direct(g.rest, 2 * g.n, vertex_range(0, g.n), {}, linear_solver(LinearSolver::Direct));
        LinearSolverOptions cg_options = linear_solver(LinearSolver::ConjugateGradient);
        cg_options.multigrid.coarsest_rows = 20;
        cg_options.cg_relative_tolerance = relative;
        const ShellSolver cg(g.rest, 2 * g.n, vertex_range(0, g.n), {}, cg_options);
        const SolveOptions options = to_convergence();
        Eigen::MatrixXd X_direct = g.X, X_cg = g.X;
        const SolveResult r_direct = direct.solve(X_direct, options);
        const SolveResult r_cg = cg.solve(X_cg, options);
        expect_monotone(r_cg.energy);
        EXPECT_TRUE(r_direct.converged);
        EXPECT_TRUE(r_cg.converged);
        EXPECT_NEAR(r_cg.energy.back(), r_direct.energy.back(), 1e-9 * r_direct.energy.front());
        EXPECT_LT((X_cg - X_direct).cwiseAbs().maxCoeff(), 1e-5 * eta);
      }
}

TEST(ShellSolver, AndersonAccelerationKeepsTheEnergyFallingToTheSameMinimum) {
  // Combined iterates are kept only when they lower the energy, so the energy never rises, and
  // the accelerated iteration ends at the plain iteration's fixed point (both paths).
  const auto cases = linear_solver_cases();
  for (const auto& [name, m] : cases)
    for (double eta : {0.02, 0.2})
      for (LinearSolver kind : {LinearSolver::Direct, LinearSolver::ConjugateGradient}) {
        SCOPED_TRACE(name + " eta " + std::to_string(eta) + (kind == LinearSolver::Direct ? " direct" : " cg"));
        Generation g = generation(m, eta);
        LinearSolverOptions linear = linear_solver(kind);
        linear.multigrid.coarsest_rows = 20;
        const ShellSolver solver(g.rest, 2 * g.n, vertex_range(0, g.n), {}, linear);
        const SolveOptions plain = to_convergence();
        SolveOptions accelerated = plain;
        accelerated.anderson_history = 5;
        Eigen::MatrixXd X_plain = g.X, X_accelerated = g.X;
        const SolveResult r_plain = solver.solve(X_plain, plain);
        const SolveResult r_accelerated = solver.solve(X_accelerated, accelerated);
        expect_monotone(r_accelerated.energy);
        EXPECT_TRUE(r_accelerated.converged);
        EXPECT_NEAR(r_accelerated.energy.back(), r_plain.energy.back(), 1e-9 * r_plain.energy.front());
        EXPECT_LT((X_accelerated - X_plain).cwiseAbs().maxCoeff(), 1e-5 * eta);
        EXPECT_TRUE(X_accelerated.topRows(g.n) == g.X.topRows(g.n)) << "fixed base moved";
      }
  Generation g = generation(test::icosphere(2), 0.1);
  const ShellSolver solver(g.rest, 2 * g.n, vertex_range(0, g.n));
  SolveOptions negative;
  negative.anderson_history = -1;
  EXPECT_THROW(solver.solve(g.X, negative), InputError);
}

TEST(ShellSolver, AutoTakesConjugateGradientForLargeAnchoredAndLargerLooseSystems) {
  const SimpleMesh m = test::torus(40, 16);
  Generation g = generation(m, 0.05);
  LinearSolverOptions any_size;
  any_size.cg_min_rows = 0;
  // Generation: every top vertex shares a tet with the fixed base.
  EXPECT_EQ(ShellSolver(g.rest, 2 * g.n, vertex_range(0, g.n), {}, any_size).linear_solver(), LinearSolver::ConjugateGradient);
  EXPECT_EQ(ShellSolver(g.rest, 2 * g.n, vertex_range(0, g.n)).linear_solver(), LinearSolver::Direct) << "small system";
  // Held at three vertices only (a pose by handles): CG from cg_loose_min_rows on, and only with
  // the multigrid (Jacobi's iterations grow with the size); never below cg_min_rows.
  const std::vector<int> three = {0, 7, 300};
  EXPECT_EQ(ShellSolver(g.rest, 2 * g.n, three, {}, any_size).linear_solver(), LinearSolver::Direct);
  LinearSolverOptions loose = any_size;
  loose.cg_loose_min_rows = 2 * g.n - 3;
  EXPECT_EQ(ShellSolver(g.rest, 2 * g.n, three, {}, loose).linear_solver(), LinearSolver::ConjugateGradient);
  loose.cg_loose_min_rows = 2 * g.n - 2;
  EXPECT_EQ(ShellSolver(g.rest, 2 * g.n, three, {}, loose).linear_solver(), LinearSolver::Direct) << "one row short";
  loose.cg_loose_min_rows = 0;
  loose.preconditioner = CgPreconditioner::Jacobi;
  EXPECT_EQ(ShellSolver(g.rest, 2 * g.n, three, {}, loose).linear_solver(), LinearSolver::Direct) << "jacobi";
  loose.preconditioner = CgPreconditioner::Multigrid;
  loose.cg_min_rows = 2 * g.n;
  EXPECT_EQ(ShellSolver(g.rest, 2 * g.n, three, {}, loose).linear_solver(), LinearSolver::Direct) << "below cg_min_rows";
}

TEST(ShellSolver, ALooselyHeldSystemOnAutosConjugateGradientReachesTheFactorsMinimum) {
  // A pose by handles: the torus's outer side held, an arc of the inner side pulled up and in.
  // Auto's CG (the multigrid, the default relative tolerance) takes other iterates than the
  // factor, each lowering the energy, and converges to the same minimum.
  const SimpleMesh m = test::torus(40, 16);
  Generation g = generation(m, 0.05);
  std::vector<int> fixed;
  Eigen::MatrixXd X = g.X;
  const double outer = g.X.leftCols(2).rowwise().norm().maxCoeff();
  for (int v = 0; v < 2 * g.n; ++v) {
    const Eigen::RowVector3d p = g.X.row(v);
    if (p.head<2>().norm() > 0.95 * outer) fixed.push_back(v);
    else if (p.head<2>().norm() < 0.8 * outer && p.x() > 0.5 * outer) {
      fixed.push_back(v);
      X.row(v) += Eigen::RowVector3d(-0.05, 0, 0.1) * outer;
    }
  }
  ASSERT_GT(fixed.size(), 20u);
  ASSERT_LT(fixed.size(), static_cast<std::size_t>(g.n)) << "not loosely held: nothing tested";
  LinearSolverOptions auto_cg;
  auto_cg.cg_min_rows = 0;
  auto_cg.cg_loose_min_rows = 0;
  auto_cg.multigrid.coarsest_rows = 20;
  const ShellSolver direct(g.rest, 2 * g.n, fixed, {}, linear_solver(LinearSolver::Direct));
  const ShellSolver cg(g.rest, 2 * g.n, fixed, {}, auto_cg);
  ASSERT_EQ(cg.linear_solver(), LinearSolver::ConjugateGradient);
  Eigen::MatrixXd X_direct = X, X_cg = X;
  const SolveResult r_direct = direct.solve(X_direct, to_convergence());
  const SolveResult r_cg = cg.solve(X_cg, to_convergence());
  EXPECT_EQ(cg.linear_solver(), LinearSolver::ConjugateGradient) << "fell back to the factor";
  EXPECT_GT(r_cg.linear_iterations, 0);
  expect_monotone(r_cg.energy);
  EXPECT_TRUE(r_direct.converged);
  EXPECT_TRUE(r_cg.converged);
  EXPECT_GT(r_direct.energy.back(), 1e-3 * r_direct.energy.front()) << "the pull left no energy: nothing tested";
  EXPECT_NEAR(r_cg.energy.back(), r_direct.energy.back(), 1e-9 * r_direct.energy.front());
  EXPECT_LT((X_cg - X_direct).cwiseAbs().maxCoeff(), 1e-5 * 0.05);
  for (int v : fixed) EXPECT_TRUE(X_cg.row(v) == X.row(v)) << "handle " << v << " moved";
}

TEST(ShellSolver, AutoFallsBackToTheFactorWhenConjugateGradientStalls) {
  Generation g = generation(test::icosphere(3), 0.2);
  const ShellSolver direct(g.rest, 2 * g.n, vertex_range(0, g.n), {}, linear_solver(LinearSolver::Direct));
  SolveOptions options;
  options.max_iterations = 5;
  options.tolerance = 0;
  Eigen::MatrixXd X_direct = g.X;
  direct.solve(X_direct, options);
  // With the multigrid the factor is made from the matrix the multigrid holds (the solver keeps
  // no copy of L_ff then); levels down to 8 rows, so that one V-cycle is not an exact solve.
  for (CgPreconditioner preconditioner : {CgPreconditioner::Jacobi, CgPreconditioner::Multigrid}) {
    LinearSolverOptions starved;
    starved.cg_min_rows = 0;
    starved.cg_max_iterations = 1; // never enough: the first global step factors instead
    starved.preconditioner = preconditioner;
    starved.multigrid.coarsest_rows = 8;
    const ShellSolver fallback(g.rest, 2 * g.n, vertex_range(0, g.n), {}, starved);
    ASSERT_EQ(fallback.linear_solver(), LinearSolver::ConjugateGradient);
    Eigen::MatrixXd X_fallback = g.X;
    fallback.solve(X_fallback, options);
    EXPECT_EQ(fallback.linear_solver(), LinearSolver::Direct);
    EXPECT_LT((X_fallback - X_direct).cwiseAbs().maxCoeff(), 1e-12);
  }
}

TEST(ShellSolver, LinearSolverNamesAndBadOptions) {
  for (LinearSolver s : {LinearSolver::Auto, LinearSolver::Direct, LinearSolver::ConjugateGradient})
    EXPECT_EQ(parse_linear_solver(to_string(s)), s);
  EXPECT_THROW(parse_linear_solver("cholesky"), InputError);
  Generation g = generation(test::icosphere(1), 0.1);
  LinearSolverOptions bad;
  bad.cg_tolerance = 0;
  EXPECT_THROW(ShellSolver(g.rest, 2 * g.n, vertex_range(0, g.n), {}, bad), InputError);
  bad = {};
  bad.cg_max_iterations = 0;
  EXPECT_THROW(ShellSolver(g.rest, 2 * g.n, vertex_range(0, g.n), {}, bad), InputError);
  bad = {};
  bad.cg_min_rows = -1;
  EXPECT_THROW(ShellSolver(g.rest, 2 * g.n, vertex_range(0, g.n), {}, bad), InputError);
  bad = {};
  bad.cg_loose_min_rows = -1;
  EXPECT_THROW(ShellSolver(g.rest, 2 * g.n, vertex_range(0, g.n), {}, bad), InputError);
}

TEST(ShellSolver, SolveGivesTheStepsBitsOnManyChunksInMeshAndShuffledOrder) {
  // solve() adds each chunk's rotations straight into the right-hand side, chunks grouped by a
  // colouring so that no two running at once share a row (or, for tets in an order too scattered
  // to colour, stores and gathers them); local_step / global_step gather in the same order.
  // On an icosphere of 61,440 tets (30 chunks) in mesh order and with its faces shuffled, both
  // must give the same bits, iteration by iteration, and the two orders the same energies.
  const SimpleMesh sphere = test::icosphere(5);
  SimpleMesh shuffled = sphere;
  std::vector<int> order(sphere.F.rows());
  std::iota(order.begin(), order.end(), 0);
  std::mt19937 rng(3);
  std::shuffle(order.begin(), order.end(), rng);
  for (int f = 0; f < sphere.F.rows(); ++f) shuffled.F.row(f) = sphere.F.row(order[f]);
  std::vector<std::vector<double>> energies;
  for (const SimpleMesh* m : {&sphere, static_cast<const SimpleMesh*>(&shuffled)}) {
    Generation g = generation(*m, 0.05);
    // A wavy start, so that every iteration has work to do.
    for (int i = g.n; i < 2 * g.n; ++i) g.X.row(i) *= 1 + 0.02 * std::sin(7 * g.X(i, 0));
    const ShellSolver solver(g.rest, 2 * g.n, vertex_range(0, g.n));
    Eigen::MatrixXd by_solve = g.X, by_steps = g.X;
    SolveOptions options;
    options.max_iterations = 4;
    options.tolerance = 0;
    const SolveResult r = solver.solve(by_solve, options);
    LocalStep step;
    solver.local_step(by_steps, step);
    EXPECT_EQ(step.energy, r.energy[0]);
    for (int k = 1; k <= 4; ++k) {
      solver.global_step(by_steps, step);
      solver.local_step(by_steps, step);
      EXPECT_EQ(step.energy, r.energy[k]) << "iteration " << k;
    }
    EXPECT_TRUE(by_steps == by_solve);
    expect_monotone(r.energy);
    energies.push_back(r.energy);
  }
  for (int k = 0; k <= 4; ++k) EXPECT_NEAR(energies[1][k], energies[0][k], 1e-12 * energies[0][0]) << "iteration " << k;
}

TEST(ShellSolver, TheAffinePrismFormGivesThePerTetShell) {
  // The normal prisms' rest tets in the affine-prism form (one inverse per prism) and per tet:
  // to rounding the same energies, steps and shell, on the direct and the CG path; a RestTets with
  // no form is refused.
  const auto cases = linear_solver_cases();
  for (const auto& [name, m] : cases)
    for (LinearSolver kind : {LinearSolver::Direct, LinearSolver::ConjugateGradient}) {
      SCOPED_TRACE(name + (kind == LinearSolver::Direct ? " direct" : " cg"));
      const double eta = 0.05;
      Generation g = generation(m, eta);
      const ShellSolver per_tet(g.rest, 2 * g.n, vertex_range(0, g.n), {}, linear_solver(kind));
      const ShellSolver affine(normal_prism_rest_tets(m.V, m.F, eta), 2 * g.n, vertex_range(0, g.n), {}, linear_solver(kind));
      ASSERT_TRUE(affine.rest().Dm_inv.empty());
      const SolveOptions options = exactly(15);
      Eigen::MatrixXd X_per_tet = g.X, X_affine = g.X;
      const SolveResult r_per_tet = per_tet.solve(X_per_tet, options);
      const SolveResult r_affine = affine.solve(X_affine, options);
      expect_monotone(r_affine.energy);
      ASSERT_EQ(r_affine.energy.size(), r_per_tet.energy.size());
      for (std::size_t k = 0; k < r_affine.energy.size(); ++k)
        EXPECT_NEAR(r_affine.energy[k], r_per_tet.energy[k], 1e-10 * r_per_tet.energy[0]) << "iteration " << k;
      EXPECT_LT((X_affine - X_per_tet).cwiseAbs().maxCoeff(), 1e-9 * eta);
      // The step-by-step API (its own gather of the rotations) agrees as well.
      LocalStep s_per_tet, s_affine;
      per_tet.local_step(g.X, s_per_tet);
      affine.local_step(g.X, s_affine);
      EXPECT_NEAR(s_affine.energy, s_per_tet.energy, 1e-12 * s_per_tet.energy);
      EXPECT_LT((affine.half_gradient(g.X, s_affine) - per_tet.half_gradient(g.X, s_per_tet)).cwiseAbs().maxCoeff(),
                1e-9 * per_tet.half_gradient(g.X, s_per_tet).cwiseAbs().maxCoeff());
    }
  Generation g = generation(test::icosphere(1), 0.05);
  g.rest.Dm_inv.clear();
  EXPECT_THROW(ShellSolver(g.rest, 2 * g.n, vertex_range(0, g.n)), InputError);
}

TEST(ShellSolver, ThePositionsFormGivesThePerTetShell) {
  // A deformation's rest tets in the positions form (inverses made in the local step and the
  // assembly from the rest points) and per tet: the same shell to rounding (the SIMD variants of
  // the local step may fuse the inverse's multiply-adds), on the direct and the CG path, with and
  // without tets whose rest shape is their own.
  for (const bool overrides : {false, true})
    for (LinearSolver kind : {LinearSolver::Direct, LinearSolver::ConjugateGradient}) {
      SCOPED_TRACE(std::string(overrides ? "overrides " : "") + (kind == LinearSolver::Direct ? "direct" : "cg"));
      const SimpleMesh m = test::torus(40, 16);
      const int n = static_cast<int>(m.V.rows());
      Eigen::MatrixXd rest_X(2 * n, 3);
      rest_X << m.V, offset_top(m.V, m.F, 0.05);
      const Eigen::MatrixXi T = build_prism_tets(m.F, n);
      const auto replace = [&](Eigen::Index t, const std::array<int, 4>&, TetCorners& U) {
        if (!overrides || t % 5 != 1) return false;
        for (int j = 1; j < 4; ++j) U.row(j) = 1.5 * U.row(j) - 0.5 * U.row(0);
        return true;
      };
      const RestTets positions = rest_tets_in_positions_form(rest_X, T, replace);
      const RestTets per_tet = rest_tets_from_corner_function(T, [&](Eigen::Index t, const std::array<int, 4>& ids, TetCorners& U) {
        for (int j = 0; j < 4; ++j) U.row(j) = rest_X.row(ids[j]);
        replace(t, ids, U);
      });
      const ShellSolver a(per_tet, 2 * n, vertex_range(0, n), {}, linear_solver(kind));
      const ShellSolver b(positions, 2 * n, vertex_range(0, n), {}, linear_solver(kind));
      // The base bent: the top follows.
      Eigen::MatrixXd X = rest_X;
      for (int i = 0; i < n; ++i) X(i, 2) += 0.3 * X(i, 0) * X(i, 0);
      Eigen::MatrixXd X_a = X, X_b = X;
      const SolveResult r_a = a.solve(X_a, exactly(10)), r_b = b.solve(X_b, exactly(10));
      expect_monotone(r_b.energy);
      ASSERT_EQ(r_a.energy.size(), r_b.energy.size());
      for (std::size_t k = 0; k < r_a.energy.size(); ++k)
        EXPECT_NEAR(r_b.energy[k], r_a.energy[k], 1e-12 * r_a.energy[0]) << "iteration " << k;
      EXPECT_LT((X_a - X_b).cwiseAbs().maxCoeff(), 1e-10);
      EXPECT_GT((X_a - X).cwiseAbs().maxCoeff(), 1e-3); // the top did move
      LocalStep s_a, s_b;
      a.local_step(X, s_a);
      b.local_step(X, s_b);
      EXPECT_NEAR(s_a.energy, s_b.energy, 1e-13 * s_a.energy);
      EXPECT_LT((a.half_gradient(X, s_a) - b.half_gradient(X, s_b)).cwiseAbs().maxCoeff(),
                1e-11 * a.half_gradient(X, s_a).cwiseAbs().maxCoeff());
    }
}
