// The min-index cut: consistent diagonals on shared side quads, positive tets that fill the prism.
#include <gshell/error.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/shell/prism_tets.h>

#include "core_test_meshes.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <array>
#include <cmath>
#include <algorithm>
#include <map>
#include <random>
#include <set>

using namespace gshell;
using gshell::test::SimpleMesh;

namespace {

std::vector<std::pair<std::string, SimpleMesh>> meshes() {
  std::vector<std::pair<std::string, SimpleMesh>> list;
  list.emplace_back("sphere", test::icosphere(2));
  list.emplace_back("torus", test::torus(24, 12));
  list.emplace_back("plane", test::plane(8, 0.2));
  list.emplace_back("sphere-permuted", test::permuted(test::icosphere(2), 7));
  list.emplace_back("torus-permuted", test::permuted(test::torus(24, 12), 11));
  list.emplace_back("plane-permuted", test::permuted(test::plane(8, 0.2), 13));
  return list;
}

// An offset shell's positions: the base, then the top eta along the vertex normals (2n x 3).
Eigen::MatrixXd offset_shell_positions(const SimpleMesh& m, double eta) {
  Eigen::MatrixXd X(2 * m.V.rows(), 3);
  X << m.V, offset_top(m.V, m.F, eta);
  return X;
}

double signed_volume(const Eigen::MatrixXd& X, const Eigen::RowVector4i& t) {
  Eigen::Matrix3d D;
  D << (X.row(t[1]) - X.row(t[0])).transpose(), (X.row(t[2]) - X.row(t[0])).transpose(),
      (X.row(t[3]) - X.row(t[0])).transpose();
  return D.determinant() / 6;
}

} // namespace

TEST(PrismTets, SharedSideQuadsUseTheSameDiagonal) {
  for (const auto& [name, m] : meshes()) {
    SCOPED_TRACE(name);
    const int n = static_cast<int>(m.V.rows());
    const Eigen::MatrixXi T = build_prism_tets(m.F, n);
    ASSERT_EQ(T.rows(), 3 * m.F.rows());
    // For every side quad (base edge i-j), the diagonal each prism uses, as a (base, top) pair.
    std::map<std::pair<int, int>, std::vector<std::pair<int, int>>> diagonals;
    for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
      std::set<std::pair<int, int>> edges;
      for (int k = 0; k < 3; ++k)
        for (int a = 0; a < 4; ++a)
          for (int b = 0; b < 4; ++b) edges.insert({T(3 * f + k, a), T(3 * f + k, b)});
      for (int k = 0; k < 3; ++k) {
        const int i = m.F(f, k), j = m.F(f, (k + 1) % 3);
        const bool ij = edges.count({i, n + j}) > 0, ji = edges.count({j, n + i}) > 0;
        ASSERT_NE(ij, ji) << "face " << f << " must cut quad " << i << "-" << j << " along exactly one diagonal";
        diagonals[std::minmax(i, j)].push_back(ij ? std::make_pair(i, n + j) : std::make_pair(j, n + i));
        // The rule itself: base(min) - top(max).
        EXPECT_EQ(ij ? i : j, std::min(i, j));
      }
    }
    int shared = 0;
    for (const auto& [edge, d] : diagonals) {
      if (d.size() == 2) {
        ++shared;
        EXPECT_EQ(d[0], d[1]) << "quad " << edge.first << "-" << edge.second;
      }
    }
    EXPECT_GT(shared, 0);
  }
}

TEST(PrismTets, CornerNumbersMatchVertexIds) {
  for (const auto& [name, m] : meshes()) {
    SCOPED_TRACE(name);
    const int n = static_cast<int>(m.V.rows());
    const Eigen::MatrixXi T = build_prism_tets(m.F, n), C = prism_tet_corners(m.F);
    ASSERT_EQ(C.rows(), T.rows());
    for (Eigen::Index t = 0; t < T.rows(); ++t)
      for (int j = 0; j < 4; ++j) {
        const int c = C(t, j);
        ASSERT_GE(c, 0);
        ASSERT_LT(c, 6);
        EXPECT_EQ(T(t, j), c < 3 ? m.F(t / 3, c) : n + m.F(t / 3, c - 3));
      }
  }
}

TEST(PrismTets, RestTetsArePositiveAndFillTheirPrism) {
  for (const auto& [name, m] : meshes()) {
    SCOPED_TRACE(name);
    const int n = static_cast<int>(m.V.rows());
    const double eta = 0.05;
    // Normal prisms, and the same prisms sheared by a constant offset (planar side faces both).
    const Eigen::MatrixXd normal = normal_prisms(m.V, m.F, eta);
    Eigen::MatrixXd sheared = normal;
    for (Eigen::Index f = 0; f < m.F.rows(); ++f)
      for (int k = 3; k < 6; ++k) sheared.row(6 * f + k) += Eigen::RowVector3d(0.3, -0.2, 0.1) * eta;
    for (const Eigen::MatrixXd* prisms : std::vector<const Eigen::MatrixXd*>{&normal, &sheared}) {
      const RestTets rest = prism_rest_tets(m.F, n, *prisms);
      ASSERT_EQ(rest.size(), 3 * m.F.rows());
      for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
        const Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
        const Eigen::Vector3d normal_dir = (b - a).cross(c - a);
        const Eigen::Vector3d shift = (*prisms).row(6 * f + 3) - (*prisms).row(6 * f);
        const double prism_volume = 0.5 * normal_dir.dot(shift); // base area x height
        double sum = 0;
        for (int k = 0; k < 3; ++k) {
          EXPECT_GT(rest.volume[3 * f + k], 0);
          sum += rest.volume[3 * f + k];
        }
        EXPECT_NEAR(sum, prism_volume, 1e-12 * std::abs(prism_volume) + 1e-15);
      }
    }
  }
}

TEST(PrismTets, OffsetShellTetsArePositivelyOriented) {
  for (const auto& [name, m] : meshes()) {
    SCOPED_TRACE(name);
    const int n = static_cast<int>(m.V.rows());
    const Eigen::MatrixXd X = offset_shell_positions(m, 0.02);
    const Eigen::MatrixXi T = build_prism_tets(m.F, n);
    for (Eigen::Index t = 0; t < T.rows(); ++t) EXPECT_GT(signed_volume(X, T.row(t)), 0) << "tet " << t;
    // The same positions as rest shapes: accepted, with the same volumes.
    const RestTets rest = rest_tets_from_positions(X, T);
    for (Eigen::Index t = 0; t < T.rows(); ++t) EXPECT_NEAR(rest.volume[t], signed_volume(X, T.row(t)), 1e-15);
  }
}

TEST(PrismTets, InvertedRestPrismIsRejected) {
  const SimpleMesh m = test::icosphere(1);
  const Eigen::MatrixXd inward = normal_prisms(m.V, m.F, -0.05);
  EXPECT_THROW(prism_rest_tets(m.F, static_cast<int>(m.V.rows()), inward), InputError);
}

TEST(PrismTets, UnitPrismTetsHaveExactIntegerInverses) {
  // Every ordered set of four unit-prism corners: C^-1 C = I exactly where the corners span a tet,
  // det C in {-1, 0, 1}, and the tets every face order is cut into are positive.
  for (int code = 0; code < 6 * 6 * 6 * 6; ++code) {
    const std::array<int, 4> corners{code % 6, code / 6 % 6, code / 36 % 6, code / 216};
    ASSERT_EQ(unit_corner_code(corners), code);
    auto corner = [](int c) { return Eigen::Vector3d(c % 3 == 1, c % 3 == 2, c >= 3); };
    Eigen::Matrix3d C;
    C << corner(corners[1]) - corner(corners[0]), corner(corners[2]) - corner(corners[0]),
        corner(corners[3]) - corner(corners[0]);
    const double det = unit_corner_determinant(static_cast<std::uint16_t>(code));
    EXPECT_EQ(det, C.determinant()) << "code " << code;
    EXPECT_TRUE(det == 0 || det == 1 || det == -1) << "code " << code;
    if (det != 0) EXPECT_TRUE(unit_corner_inverses()[code] * C == Eigen::Matrix3d::Identity()) << "code " << code;
  }
  for (const std::array<int, 3>& ids : std::vector<std::array<int, 3>>{{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}})
    for (const auto& tet : prism_corner_tets(ids[0], ids[1], ids[2])) EXPECT_EQ(unit_corner_determinant(unit_corner_code(tet)), 1);
  EXPECT_THROW(unit_corner_code({0, 1, 2, 6}), InputError);
}

TEST(PrismTets, NormalPrismRestTetsInTheAffineFormAreThePerTetOnes) {
  // The affine-prism form of the normal prisms' rest tets: the same tets and, to rounding, the
  // same rest shapes and volumes as the per-tet form made from the prisms' corners.
  for (const auto& [name, m] : meshes()) {
    SCOPED_TRACE(name);
    const int n = static_cast<int>(m.V.rows());
    const double eta = 0.05;
    const RestTets per_tet = prism_rest_tets(m.F, n, normal_prisms(m.V, m.F, eta));
    const RestTets affine = normal_prism_rest_tets(m.V, m.F, eta);
    EXPECT_TRUE(affine.Dm_inv.empty());
    EXPECT_TRUE(affine.complete());
    ASSERT_TRUE(affine.T == per_tet.T);
    for (int t = 0; t < affine.size(); ++t) {
      const Eigen::Matrix3d want = per_tet.dm_inv(t);
      EXPECT_LE((affine.dm_inv(t) - want).norm(), 1e-12 * want.norm()) << "tet " << t;
      EXPECT_NEAR(affine.volume[t], per_tet.volume[t], 1e-12 * per_tet.volume[t]) << "tet " << t;
    }
  }
  const SimpleMesh m = test::icosphere(1);
  EXPECT_THROW(normal_prism_rest_tets(m.V, m.F, -0.05), InputError); // turned inside out
  EXPECT_THROW(normal_prism_rest_tets(m.V, m.F, std::nan("")), InputError);
  SimpleMesh flat = m;
  flat.V.row(flat.F(0, 2)) = flat.V.row(flat.F(0, 0)); // face 0 has no area
  EXPECT_THROW(normal_prism_rest_tets(flat.V, flat.F, 0.05), InputError);
}

TEST(PrismTets, InverseEdgeMatrixIsEigensInverse) {
  // One 3x3 inverse for every form of rest tets and the solver's kernel: Eigen's, bit for bit (so
  // the per-tet form kept its bits when it moved to it), with the edge matrix's determinant.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-2, 2);
  for (int k = 0; k < 1000; ++k) {
    double x[4][3];
    for (auto& p : x)
      for (double& c : p) c = u(rng);
    Eigen::Matrix3d D;
    for (int j = 0; j < 3; ++j)
      for (int r = 0; r < 3; ++r) D(r, j) = x[j + 1][r] - x[0][r];
    Eigen::Matrix3d mine;
    const double det = detail::inverse_edge_matrix(x[0], x[1], x[2], x[3], mine.data());
    const Eigen::Matrix3d eigen = D.inverse();
    for (int i = 0; i < 9; ++i) EXPECT_EQ(mine.data()[i], eigen.data()[i]) << "case " << k << " entry " << i;
    EXPECT_NEAR(det, D.determinant(), 1e-12 * D.cwiseAbs().maxCoeff() * D.cwiseAbs().maxCoeff() * D.cwiseAbs().maxCoeff());
  }
}

TEST(PrismTets, RestTetsInThePositionsFormAreThePerTetOnes) {
  // A shell's own tets in the positions form (no matrix per tet, the inverse made where it is
  // read): the same bits as the per-tet form; replaced tets keep their own matrix, listed in order.
  for (const auto& [name, m] : meshes()) {
    SCOPED_TRACE(name);
    const int n = static_cast<int>(m.V.rows());
    const Eigen::MatrixXd X = offset_shell_positions(m, 0.05);
    const Eigen::MatrixXi T = build_prism_tets(m.F, n);
    const RestTets per_tet = rest_tets_from_positions(X, T);
    // Every seventh tet replaced by its corners scaled by 2 about the first.
    const auto replace = [&](Eigen::Index t, const std::array<int, 4>&, TetCorners& U) {
      if (t % 7 != 3) return false;
      for (int j = 1; j < 4; ++j) U.row(j) = 2 * U.row(j) - U.row(0);
      return true;
    };
    const RestTets positions = rest_tets_in_positions_form(X, T, replace);
    EXPECT_TRUE(positions.Dm_inv.empty());
    EXPECT_TRUE(positions.complete());
    ASSERT_TRUE(positions.T == T);
    ASSERT_EQ(positions.override_tets.size(), static_cast<std::size_t>((T.rows() + 3) / 7));
    EXPECT_TRUE(std::is_sorted(positions.override_tets.begin(), positions.override_tets.end()));
    for (int t = 0; t < positions.size(); ++t) {
      const double scale = t % 7 == 3 ? 2 : 1;
      const Eigen::Matrix3d got = positions.dm_inv(t), want = per_tet.dm_inv(t) / scale;
      EXPECT_LE((got - want).norm(), 1e-12 * want.norm()) << "tet " << t;
      EXPECT_NEAR(positions.volume[t], scale * scale * scale * per_tet.volume[t], 1e-12 * positions.volume[t]);
      if (scale == 1) EXPECT_TRUE(got == per_tet.dm_inv(t)) << "tet " << t; // bit for bit
    }
    EXPECT_TRUE(rest_tets_in_positions_form(X, T).override_tets.empty());
  }
  const SimpleMesh m = test::icosphere(1);
  const int n = static_cast<int>(m.V.rows());
  const Eigen::MatrixXd X = offset_shell_positions(m, 0.05);
  const Eigen::MatrixXi T = build_prism_tets(m.F, n);
  EXPECT_THROW(rest_tets_in_positions_form(offset_shell_positions(m, -0.05), T), InputError); // inside out
  Eigen::MatrixXd nan = X;
  nan(n + 2, 1) = std::nan("");
  EXPECT_THROW(rest_tets_in_positions_form(nan, T), InputError);
  Eigen::MatrixXi out_of_range = T;
  out_of_range(4, 2) = 2 * n;
  EXPECT_THROW(rest_tets_in_positions_form(X, out_of_range), InputError);
  EXPECT_THROW(rest_tets_in_positions_form(X.leftCols(2), T), InputError);
  // complete() sees what the local step would read wrongly: too few rest points, overrides out
  // of order or out of range.
  const auto swap_every_other = [](Eigen::Index t, const std::array<int, 4>&, TetCorners& U) {
    if (t % 2 != 0) return false;
    U.row(1).swap(U.row(2));
    U.row(1).swap(U.row(3));
    return true;
  };
  RestTets shapes = rest_tets_in_positions_form(X, T, swap_every_other);
  ASSERT_TRUE(shapes.complete());
  ASSERT_GE(shapes.override_tets.size(), 2u);
  RestTets unsorted = shapes;
  std::swap(unsorted.override_tets[0], unsorted.override_tets[1]);
  EXPECT_FALSE(unsorted.complete());
  RestTets beyond = shapes;
  beyond.override_tets.back() = shapes.size();
  EXPECT_FALSE(beyond.complete());
  RestTets few_points = shapes;
  few_points.rest_points.resize(few_points.rest_points.size() - 3);
  EXPECT_FALSE(few_points.complete());
  // A replacement that turns a tet inside out is refused like any other rest shape.
  EXPECT_THROW(rest_tets_in_positions_form(X, T,
                                           [](Eigen::Index t, const std::array<int, 4>&, TetCorners& U) {
                                             if (t != 5) return false;
                                             U.row(1).swap(U.row(2));
                                             return true;
                                           }),
               InputError);
}
