// The boundary surface of the layer: closed, consistently oriented outwards, made of tet faces.
#include <gshell/error.h>
#include <gshell/quality/shell_boundary.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/shell/prism_tets.h>

#include "core_test_meshes.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <map>
#include <set>

using namespace gshell;
using gshell::test::SimpleMesh;

namespace {

std::vector<std::pair<std::string, SimpleMesh>> meshes() {
  return {{"sphere", test::icosphere(2)},
          {"torus", test::torus(24, 12)},
          {"plane", test::plane(6, 0.2)},
          {"plane-permuted", test::permuted(test::plane(6, 0.2), 5)}};
}

// Signed volume enclosed by a closed triangle surface (divergence theorem).
double enclosed_volume(const Eigen::MatrixXd& X, const Eigen::MatrixXi& F) {
  double v = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
  {
    const Eigen::Vector3d a = X.row(F(f, 0)), b = X.row(F(f, 1)), c = X.row(F(f, 2));
    v += a.dot(b.cross(c)) / 6;
  }
  return v;
}

} // namespace

TEST(ShellBoundary, EveryEdgeIsUsedOnceInEachDirection) {
  for (const auto& [name, m] : meshes()) {
    SCOPED_TRACE(name);
    const int n = static_cast<int>(m.V.rows());
    const ShellBoundary b = shell_boundary(m.F, n);
    std::map<std::pair<int, int>, int> directed;
    for (int r = 0; r < b.size(); ++r)
      for (int k = 0; k < 3; ++k) ++directed[{b.F(r, k), b.F(r, (k + 1) % 3)}];
    for (const auto& [edge, count] : directed) {
      EXPECT_EQ(count, 1) << edge.first << "->" << edge.second;
      EXPECT_EQ(directed.count({edge.second, edge.first}), 1u) << edge.first << "->" << edge.second;
    }
  }
}

TEST(ShellBoundary, EnclosesTheTetsOfAnOffsetShellWithOutwardNormals) {
  for (const auto& [name, m] : meshes()) {
    SCOPED_TRACE(name);
    const int n = static_cast<int>(m.V.rows());
    Eigen::MatrixXd X(2 * n, 3);
    X << m.V, offset_top(m.V, m.F, 0.05);
    const Eigen::MatrixXi T = build_prism_tets(m.F, n);
    double tets = 0;
    for (Eigen::Index t = 0; t < T.rows(); ++t) {
      Eigen::Matrix3d D;
      for (int j = 0; j < 3; ++j) D.col(j) = (X.row(T(t, j + 1)) - X.row(T(t, 0))).transpose();
      tets += D.determinant() / 6;
    }
    const ShellBoundary b = shell_boundary(m.F, n);
    EXPECT_GT(tets, 0);
    EXPECT_NEAR(enclosed_volume(X, b.F), tets, 1e-9 * std::abs(tets));
  }
}

TEST(ShellBoundary, WallsAreFacesOfThePrismTetsAndOnlyOnOpenSurfaces) {
  for (const auto& [name, m] : meshes()) {
    SCOPED_TRACE(name);
    const int n = static_cast<int>(m.V.rows());
    const int faces = static_cast<int>(m.F.rows());
    const ShellBoundary b = shell_boundary(m.F, n);
    const Eigen::MatrixXi T = build_prism_tets(m.F, n);
    std::set<std::array<int, 3>> tet_faces;
    for (Eigen::Index t = 0; t < T.rows(); ++t)
      for (int skip = 0; skip < 4; ++skip) {
        std::array<int, 3> tri;
        int k = 0;
        for (int j = 0; j < 4; ++j)
          if (j != skip) tri[k++] = T(t, j);
        std::sort(tri.begin(), tri.end());
        tet_faces.insert(tri);
      }
    int walls = 0;
    for (int r = 0; r < b.size(); ++r) {
      std::array<int, 3> tri{b.F(r, 0), b.F(r, 1), b.F(r, 2)};
      std::sort(tri.begin(), tri.end());
      EXPECT_TRUE(tet_faces.count(tri)) << "row " << r << " is not a face of a prism tet";
      ASSERT_GE(b.face[r], 0);
      ASSERT_LT(b.face[r], faces);
      if (b.part[r] == BoundaryPart::Wall) {
        ++walls;
        EXPECT_GE(r, 2 * faces);
      } else {
        EXPECT_EQ(b.face[r], r % faces);
        EXPECT_EQ(b.part[r], r < faces ? BoundaryPart::Base : BoundaryPart::Top);
      }
    }
    EXPECT_EQ(walls > 0, name.rfind("plane", 0) == 0);
  }
}

TEST(ShellBoundary, BadFacesAreInputErrors) {
  Eigen::MatrixXi F(1, 3);
  F << 0, 1, 3;
  EXPECT_THROW(shell_boundary(F, 3), InputError);
  F << 0, 1, 1;
  EXPECT_THROW(shell_boundary(F, 3), InputError);
}
