// The aggregation multigrid preconditioner: a symmetric positive definite V-cycle, monotone PCG
// convergence in the energy norm, iteration counts that do not grow with the resolution, and
// the shell solver's multigrid-preconditioned global steps against the factor.
#include <gshell/error.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/solver/aggregation_multigrid.h>
#include <gshell/solver/shell_solver.h>

#include "core_test_meshes.h"
#include "shell_fixtures.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <Eigen/Eigenvalues>
#include <Eigen/SparseCholesky>
#include <functional>
#include <numeric>
#include <random>
#include <thread>

using namespace gshell;
using gshell::test::SimpleMesh;
using SpMat = Eigen::SparseMatrix<double, Eigen::RowMajor>;

namespace {

LinearSolverOptions cg_options(CgPreconditioner preconditioner, int coarsest_rows = 2000) {
  LinearSolverOptions o;
  o.kind = LinearSolver::ConjugateGradient;
  o.preconditioner = preconditioner;
  o.multigrid.coarsest_rows = coarsest_rows;
  return o;
}

// The global step's matrix A_ff of generating a shell of thickness eta on m (normal prisms as
// rest shapes, base kept; top vertices in vertex order), read back from the solver.
SpMat generation_matrix(const SimpleMesh& m, double eta) {
  const int n = static_cast<int>(m.V.rows());
  const ShellSolver solver(prism_rest_tets(m.F, n, normal_prisms(m.V, m.F, eta)), 2 * n, test::vertex_range(0, n), {},
                           cg_options(CgPreconditioner::Jacobi));
  const Eigen::SparseMatrix<double, Eigen::RowMajor> rows = solver.system_rows(test::vertex_range(n, n));
  return rows.rightCols(n);
}

struct PcgRun {
  int iterations = 0;
  std::vector<double> energy_error; // ||x_k - x*||_A, from x_0 = 0
};

// Textbook preconditioned CG on A x = b from 0 until ||r|| <= tol ||b||, recording the energy
// norm of the error against `exact`.
PcgRun pcg(const SpMat& A, const Eigen::VectorXd& b, const Eigen::VectorXd& exact,
           const std::function<void(const Eigen::VectorXd&, Eigen::VectorXd&)>& precondition, double tol) {
  PcgRun run;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(b.size()), r = b, z(b.size());
  auto energy_error = [&] {
    const Eigen::VectorXd e = x - exact;
    return std::sqrt(e.dot(A * e));
  };
  run.energy_error.push_back(energy_error());
  precondition(r, z);
  Eigen::VectorXd p = z;
  double rz = r.dot(z);
  while (r.norm() > tol * b.norm() && run.iterations < 1000) {
    const Eigen::VectorXd q = A * p;
    const double alpha = rz / p.dot(q);
    x += alpha * p;
    r -= alpha * q;
    precondition(r, z);
    const double rz_next = r.dot(z);
    p = z + (rz_next / rz) * p;
    rz = rz_next;
    ++run.iterations;
    run.energy_error.push_back(energy_error());
  }
  return run;
}

Eigen::VectorXd random_vector(Eigen::Index n, unsigned seed) {
  std::mt19937 random(seed);
  std::normal_distribution<double> normal;
  Eigen::VectorXd v(n);
  for (Eigen::Index i = 0; i < n; ++i) v[i] = normal(random);
  return v;
}

} // namespace

TEST(AggregationMultigrid, VCycleIsASymmetricPositiveDefiniteMapThatUnderestimatesTheInverse) {
  // With a small coarsest level the sphere's and torus's systems get 3-4 levels. M^-1, applied to
  // every unit vector at once, is symmetric and positive definite, and the eigenvalues of M^-1 A
  // lie in (0, 1]: the V-cycle's error propagation I - M^-1 A is A-non-negative (convergent
  // smoother, exact coarsest solve).
  const std::vector<std::pair<std::string, SimpleMesh>> cases = {{"sphere", test::icosphere(3)},
                                                                 {"torus", test::torus(40, 16)}};
  for (const auto& [name, m] : cases) {
    SCOPED_TRACE(name);
    const SpMat A = generation_matrix(m, 0.3);
    MultigridOptions options;
    options.coarsest_rows = 20;
    const AggregationMultigrid mg(A, options);
    ASSERT_GE(mg.levels().size(), 3u);
    const Eigen::Index n = A.rows();
    Eigen::MatrixXd M(n, n);
    mg.apply(Eigen::MatrixXd::Identity(n, n), M);
    EXPECT_LT((M - M.transpose()).cwiseAbs().maxCoeff(), 1e-10 * M.cwiseAbs().maxCoeff());
    const Eigen::MatrixXd Ms = 0.5 * (M + M.transpose());
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Ms).eigenvalues().minCoeff(), 0.0);
    // M^-1 A's spectrum = that of the symmetric A^1/2 M^-1 A^1/2, via the generalised problem
    // A v = mu M^-1... simpler: eigenvalues of M^-1 A are the ones of L^T M L for A = L L^T.
    const Eigen::LLT<Eigen::MatrixXd> llt{Eigen::MatrixXd(A)};
    const Eigen::MatrixXd L = llt.matrixL();
    const Eigen::VectorXd mu = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(L.transpose() * Ms * L).eigenvalues();
    EXPECT_GT(mu.minCoeff(), 0.0);
    EXPECT_LE(mu.maxCoeff(), 1.0 + 1e-9);
  }
}

TEST(AggregationMultigrid, HierarchyAndCycleDoNotDependOnTheThreadCount) {
  // The setup (power iterations, prolongation, Galerkin products) and the cycle run in parallel
  // over blocks of rows; their sums are taken in a fixed order, so one thread and all of them
  // give the same bits (the shell solver's energies must not depend on the machine).
  const SpMat A = generation_matrix(test::icosphere(5), 0.3); // 10,242 rows: several blocks
  Eigen::MatrixXd R(A.rows(), 3);
  for (int c = 0; c < 3; ++c) R.col(c) = random_vector(A.rows(), 20 + c);
  MultigridOptions options;
  options.coarsest_rows = 50;
  auto run = [&](int threads, std::vector<MultigridLevelInfo>& levels) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    const AggregationMultigrid mg(A, options);
    levels = mg.levels();
    Eigen::MatrixXd Z(A.rows(), 3);
    mg.apply(R, Z);
    return Z;
  };
  std::vector<MultigridLevelInfo> one_levels, all_levels;
  const Eigen::MatrixXd one = run(1, one_levels);
  const Eigen::MatrixXd all = run(static_cast<int>(std::max(2u, std::thread::hardware_concurrency())), all_levels);
  ASSERT_GE(one_levels.size(), 3u);
  ASSERT_EQ(one_levels.size(), all_levels.size());
  for (std::size_t l = 0; l < one_levels.size(); ++l) {
    EXPECT_EQ(one_levels[l].rows, all_levels[l].rows);
    EXPECT_EQ(one_levels[l].nonzeros, all_levels[l].nonzeros);
  }
  EXPECT_TRUE(one == all) << "max difference " << (one - all).cwiseAbs().maxCoeff();
}

TEST(AggregationMultigrid, PcgConvergesMonotonicallyInTheEnergyNorm) {
  const SpMat A = generation_matrix(test::icosphere(5), 0.3);
  const Eigen::VectorXd b = random_vector(A.rows(), 7);
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> direct{Eigen::SparseMatrix<double>(A)};
  const Eigen::VectorXd exact = direct.solve(b);
  MultigridOptions options;
  options.coarsest_rows = 50;
  const AggregationMultigrid mg(A, options);
  const PcgRun run = pcg(A, b, exact, [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { mg.apply(r, z); }, 1e-10);
  for (std::size_t k = 1; k < run.energy_error.size(); ++k)
    EXPECT_LT(run.energy_error[k], run.energy_error[k - 1]) << "iteration " << k;
  EXPECT_LT(run.energy_error.back(), 1e-8 * run.energy_error.front());
}

TEST(AggregationMultigrid, IterationsDoNotGrowWithTheResolution) {
  // Generation at a fixed thickness on spheres with 4x the vertices per level: Jacobi-PCG needs
  // about twice the iterations per level (65, 128, 249 when written), the V-cycle about the same
  // number (8, 9, 10 with one more level at sphere:6).
  std::vector<int> multigrid, jacobi;
  for (int level : {4, 5, 6}) {
    const SpMat A = generation_matrix(test::icosphere(level), 0.3);
    const Eigen::VectorXd b = random_vector(A.rows(), 11);
    MultigridOptions options;
    options.coarsest_rows = 100; // 3 levels at sphere:4, 4 at sphere:6
    const AggregationMultigrid mg(A, options);
    const Eigen::VectorXd d = A.diagonal().cwiseInverse();
    const Eigen::VectorXd none = Eigen::VectorXd::Zero(A.rows()); // error norms unused here
    multigrid.push_back(
        pcg(A, b, none, [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { mg.apply(r, z); }, 1e-8).iterations);
    jacobi.push_back(
        pcg(A, b, none, [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { z = d.cwiseProduct(r); }, 1e-8).iterations);
  }
  EXPECT_LE(multigrid[2], multigrid[0] + 2);
  EXPECT_LE(multigrid[1], multigrid[0] + 2);
  EXPECT_GT(jacobi[2], 2 * jacobi[0]) << "the case should be hard for the diagonal";
}

