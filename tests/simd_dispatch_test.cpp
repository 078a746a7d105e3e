// The SIMD kernels' variants (AVX-512, AVX2 + FMA, baseline), picked at run time, agree: every
// level this CPU supports is run on the same inputs and compared with the baseline one. (On a CPU
// without AVX-512 or AVX2 the levels it lacks cannot run here and are skipped.)
#include <gshell/error.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/quality/stretch.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/solver/polar_decomposition.h>
#include <gshell/solver/shell_solver.h>
#include <gshell/solver/simd_level.h>

#include "shell_fixtures.h"

#include <gtest/gtest.h>

#include <Eigen/LU>

#include <cstdio>
#include <numeric>
#include <random>
#include <vector>

using namespace gshell;

namespace {

// Restores the level in use when a test ends.
struct LevelGuard {
  SimdLevel saved = simd_level();
  ~LevelGuard() { set_simd_level(saved); }
};

std::vector<SimdLevel> runnable_levels() {
  std::vector<SimdLevel> levels;
  for (SimdLevel l : {SimdLevel::Generic, SimdLevel::Avx2, SimdLevel::Avx512})
    if (l <= simd_level_supported()) levels.push_back(l);
  return levels;
}

double max_relative_difference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).cwiseAbs().maxCoeff() / std::max(1.0, b.cwiseAbs().maxCoeff());
}

} // namespace

TEST(SimdLevel, NamesRoundTripAndUnsupportedLevelsAreRefused) {
  for (SimdLevel l : {SimdLevel::Generic, SimdLevel::Avx2, SimdLevel::Avx512}) EXPECT_EQ(parse_simd_level(to_string(l)), l);
  EXPECT_THROW(parse_simd_level("sse9"), InputError);
  EXPECT_LE(simd_level(), simd_level_supported());
  LevelGuard guard;
  set_simd_level(SimdLevel::Generic); // every CPU runs the baseline
  EXPECT_EQ(simd_level(), SimdLevel::Generic);
  if (simd_level_supported() < SimdLevel::Avx512) EXPECT_THROW(set_simd_level(SimdLevel::Avx512), InputError);
  std::printf("SIMD levels supported here: up to %s\n", to_string(simd_level_supported()).c_str());
}

TEST(SimdLevel, BatchedPolarDecompositionsAgreeAcrossLevels) {
  // Near rotations (Newton lanes) mixed with inverted, singular and tiny ones (SVD lanes), and a
  // count that is not a multiple of the lane width.
  std::mt19937 rng(11);
  std::normal_distribution<double> g(0, 0.3);
  std::vector<Eigen::Matrix3d> F(2051);
  for (std::size_t i = 0; i < F.size(); ++i) {
    for (int k = 0; k < 9; ++k) F[i](k / 3, k % 3) = (k % 4 == 0) + g(rng);
    if (i % 7 == 0) F[i].col(0) *= -1;
    if (i % 11 == 0) F[i].col(2) = F[i].col(0) + F[i].col(1);
    if (i % 13 == 0) F[i] *= 1e-160;
  }
  LevelGuard guard;
  for (SimdLevel level : runnable_levels()) {
    set_simd_level(level);
    std::vector<Eigen::Matrix3d> R(F.size());
    closest_rotations(F.data(), R.data(), F.size());
    for (std::size_t i = 0; i < F.size(); ++i) {
      EXPECT_LT((R[i] - closest_rotation(F[i])).cwiseAbs().maxCoeff(), 1e-12) << to_string(level) << " matrix " << i;
      EXPECT_LT((R[i].transpose() * R[i] - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
      EXPECT_NEAR(R[i].determinant(), 1.0, 1e-12);
    }
  }
}

TEST(SimdLevel, SolverAndStretchAgreeAcrossLevels) {
  // The rigid shell of a sphere: rest tets of the normal prisms, base fixed, top from the offset.
  const TriMesh sphere = make_sphere(3);
  const int n = sphere.num_vertices();
  const double eta = 0.1;
  const RestTets rest = prism_rest_tets(sphere.F, n, normal_prisms(sphere.V, sphere.F, eta));
  const std::vector<int> base = test::vertex_range(0, n);
  const ShellSolver solver(rest, 2 * n, base);
  const Eigen::MatrixXd X0 = test::sphere_shell(3, eta).vertices();
  SolveOptions five;
  five.max_iterations = 5;
  five.tolerance = 0;

  LevelGuard guard;
  set_simd_level(SimdLevel::Generic);
  Eigen::MatrixXd X_generic = X0;
  const SolveResult generic = solver.solve(X_generic, five);
  const Eigen::VectorXd stretch_generic = tet_stretch(rest, X_generic);
  ASSERT_GT(generic.energy.front(), generic.energy.back()); // the solve does something to compare
  for (SimdLevel level : runnable_levels()) {
    set_simd_level(level);
    Eigen::MatrixXd X = X0;
    const SolveResult r = solver.solve(X, five);
    ASSERT_EQ(r.energy.size(), generic.energy.size());
    for (std::size_t k = 0; k < r.energy.size(); ++k)
      EXPECT_NEAR(r.energy[k], generic.energy[k], 1e-12 * generic.energy[k]) << to_string(level) << " iteration " << k;
    EXPECT_LT(max_relative_difference(X, X_generic), 1e-12) << to_string(level);
    EXPECT_NEAR(solver.energy(X), r.energy.back(), 1e-12 * r.energy.back());
    EXPECT_LT(max_relative_difference(tet_stretch(rest, X_generic), stretch_generic), 1e-12) << to_string(level);
  }
}
