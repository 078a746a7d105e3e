// The guarded solver's exact solves with A + H (guard/low_rank_inverse.h): A a shell's system
// matrix, H positive semidefinite over a few vertices. Checked by their residual, computed with A
// and H directly, over changing vertex sets that make the kept block of A^-1 let go of vertices.
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/solver/rest_tets.h>
#include <gshell/solver/shell_solver.h>

#include <gtest/gtest.h>

#include "guard/low_rank_inverse.h"

#include <numeric>
#include <random>
#include <vector>

using namespace gshell;

namespace {

struct SphereSystem {
  TriMesh base = make_sphere(2);
  int n = static_cast<int>(base.V.rows());
  ShellSolver A{prism_rest_tets(base.F, n, normal_prisms(base.V, base.F, 0.1)), 2 * n, base_vertices()};
  int nf = static_cast<int>(A.free_vertices().size());

  std::vector<int> base_vertices() const {
    std::vector<int> fixed(n);
    std::iota(fixed.begin(), fixed.end(), 0);
    return fixed;
  }
};

// A random positive semidefinite matrix over the coordinates of `count` vertices, of rank 4
// (singular, as a few contact pairs' Hessian is) and entries up to `scale`.
Eigen::SparseMatrix<double> low_rank_psd(int count, double scale, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::MatrixXd B(3 * count, 4);
  for (int i = 0; i < B.rows(); ++i)
    for (int j = 0; j < B.cols(); ++j) B(i, j) = u(rng);
  const Eigen::MatrixXd H = scale * B * B.transpose();
  return H.sparseView();
}

// || (A + H) x - b || / || b ||, H over `vertices`' coordinates.
double relative_residual(const SphereSystem& s, const std::vector<int>& vertices, const Eigen::SparseMatrix<double>& H,
                         const Eigen::MatrixXd& x, const Eigen::MatrixXd& b) {
  Eigen::MatrixXd r = s.A.multiply_free(x) - b;
  Eigen::VectorXd xS(3 * vertices.size());
  for (std::size_t k = 0; k < vertices.size(); ++k) xS.segment<3>(3 * k) = x.row(vertices[k]).transpose();
  const Eigen::VectorXd HxS = H * xS;
  for (std::size_t k = 0; k < vertices.size(); ++k) r.row(vertices[k]) += HxS.segment<3>(3 * k).transpose();
  return r.norm() / b.norm();
}

} // namespace

TEST(LowRankInverse, SolvesWithAPlusHExactlyAsTheVertexSetChanges) {
  const SphereSystem s;
  std::mt19937 rng(7);
  const Eigen::MatrixXd b = Eigen::MatrixXd::Random(s.nf, 3);
  Eigen::MatrixXd y = b;
  s.A.apply_inverse(y);
  detail::LowRankInverse inverse(10);
  // 8 vertices, then 8 of which 3 are shared (5 new: room made by letting go of S1's others),
  // then the second set again (nothing new to solve), each with soft and stiff H.
  const std::vector<int> first{0, 5, 9, 14, 20, 21, 33, 40}, second{9, 14, 40, 50, 51, 60, 61, 70};
  const std::vector<std::pair<const std::vector<int>*, long>> sets{{&first, 8}, {&second, 13}, {&second, 13}};
  for (const auto& [vertices, solved] : sets)
    for (double scale : {1.0, 1e6}) {
      const Eigen::SparseMatrix<double> H = low_rank_psd(static_cast<int>(vertices->size()), scale, rng);
      Eigen::MatrixXd x;
      ASSERT_TRUE(inverse.solve(s.A, *vertices, H, y, x));
      // Stiff H (scaled by 1e6) loses digits in the small system; the CG
      // directions this replaces stop at a relative residual of 0.1.
      EXPECT_LT(relative_residual(s, *vertices, H, x, b), scale > 1 ? 1e-2 : 1e-9) << "scale " << scale;
      EXPECT_EQ(inverse.columns_solved(), solved);
      // H matters: the solve is not A's alone.
      EXPECT_GT((x - y).norm(), 1e-6 * y.norm());
    }
}

TEST(LowRankInverse, DeclinesMoreVerticesThanItsCapacityAndLeavesTheResultAlone) {
  const SphereSystem s;
  std::mt19937 rng(3);
  const Eigen::MatrixXd y = Eigen::MatrixXd::Random(s.nf, 3);
  std::vector<int> vertices(11);
  std::iota(vertices.begin(), vertices.end(), 0);
  Eigen::MatrixXd x = Eigen::MatrixXd::Constant(2, 2, 5.0);
  detail::LowRankInverse inverse(10), off;
  EXPECT_FALSE(inverse.solve(s.A, vertices, low_rank_psd(11, 1.0, rng), y, x));
  EXPECT_EQ(x, Eigen::MatrixXd::Constant(2, 2, 5.0));
  EXPECT_EQ(inverse.columns_solved(), 0);
  vertices.resize(1);
  EXPECT_FALSE(off.solve(s.A, vertices, low_rank_psd(1, 1.0, rng), y, x)); // capacity 0
}
