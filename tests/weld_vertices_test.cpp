// Welding a surface's cuts: a triangle soup and a seam-split patch come back as the surfaces they
// were cut from; coincidences that are not cuts are left alone. Validation warns of every cut.
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/geometry/weld_vertices.h>

#include "shell_fixtures.h"

#include <gtest/gtest.h>

#include <string>

using namespace gshell;

namespace {

/// The plane cut along x = 0: the faces right of the cut use copies of the cut's vertices,
/// appended after the others. `copies` receives how many.
TriMesh cut_plane(int res, int* copies) {
  TriMesh m = make_plane(res);
  const Eigen::Index n = m.V.rows();
  std::vector<int> copy(n, -1);
  int added = 0;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const double centre_x = (m.V(m.F(f, 0), 0) + m.V(m.F(f, 1), 0) + m.V(m.F(f, 2), 0)) / 3;
    if (centre_x < 0) continue;
    for (int k = 0; k < 3; ++k) {
      const int v = m.F(f, k);
      if (m.V(v, 0) != 0) continue;
      if (copy[v] < 0) {
        copy[v] = static_cast<int>(n) + added++;
        m.V.conservativeResize(n + added, 3);
        m.V.row(copy[v]) = m.V.row(v);
      }
      m.F(f, k) = copy[v];
    }
  }
  *copies = added;
  return m;
}

} // namespace

TEST(WeldVertices, ASeamSplitPatchWeldsBackToTheSameMeshAndVertexOrder) {
  int copies = 0;
  const TriMesh cut = cut_plane(8, &copies);
  ASSERT_EQ(copies, 9); // the column x = 0 of a 9 x 9 grid
  int merged = -1;
  const TriMesh welded = weld_boundary_vertices(cut, &merged);
  EXPECT_EQ(merged, copies);
  const TriMesh plane = make_plane(8);
  EXPECT_TRUE(welded.V == plane.V);
  EXPECT_TRUE(welded.F == plane.F);
}

// The cut's copies moved off by rounding-sized amounts: apart for the exact weld, joined within a
// tolerance, each to the vertex it copies (the lower id), whose position is kept; `ids` maps
// every vertex of the cut to the plane's.
TEST(WeldVertices, ATolerancedWeldJoinsCopiesMovedByRounding) {
  int copies = 0;
  TriMesh cut = cut_plane(8, &copies);
  const Eigen::Index n = cut.V.rows() - copies;
  for (Eigen::Index v = n; v < cut.V.rows(); ++v) cut.V(v, (v % 3)) += (v % 2 ? 1 : -1) * 3e-14;
  int merged = -1;
  weld_boundary_vertices(cut, &merged);
  EXPECT_EQ(merged, 0);
  std::vector<int> ids;
  const TriMesh welded = weld_boundary_vertices(cut, &merged, &ids, 1e-13);
  EXPECT_EQ(merged, copies);
  const TriMesh plane = make_plane(8);
  EXPECT_TRUE(welded.V == plane.V);
  EXPECT_TRUE(welded.F == plane.F);
  ASSERT_EQ(static_cast<Eigen::Index>(ids.size()), cut.V.rows());
  for (Eigen::Index v = 0; v < cut.V.rows(); ++v)
    EXPECT_LT((plane.V.row(ids[v]) - cut.V.row(v)).norm(), 1e-13) << v;
  // Below the offsets, nothing is joined.
  weld_boundary_vertices(cut, &merged, nullptr, 1e-15);
  EXPECT_EQ(merged, 0);
}

TEST(WeldVertices, ATriangleSoupWeldsBackToAClosedSurfaceWithTheSameFaces) {
  const TriMesh sphere = make_sphere(2);
  const TriMesh soup = test::triangle_soup(sphere);
  int merged = 0;
  const TriMesh welded = weld_boundary_vertices(soup, &merged);
  EXPECT_EQ(welded.V.rows(), sphere.V.rows());
  EXPECT_EQ(merged, soup.V.rows() - sphere.V.rows());
  ASSERT_EQ(welded.F.rows(), sphere.F.rows());
  for (Eigen::Index f = 0; f < sphere.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(welded.V.row(welded.F(f, k)) == sphere.V.row(sphere.F(f, k)));
  EXPECT_TRUE(validate_mesh(welded).empty()); // closed, manifold, oriented: no problem at all
}

TEST(WeldVertices, CoincidencesThatAreNotCutsAreLeftAlone) {
  // Two closed spheres touching at one vertex: no boundary, nothing to weld, nothing to warn of.
  const TriMesh a = make_sphere(1);
  const Eigen::Index n = a.V.rows();
  TriMesh both;
  both.V.resize(2 * n, 3);
  both.V << a.V, (a.V.rowwise() + Eigen::RowVector3d(2, 0, 0));
  both.F.resize(2 * a.F.rows(), 3);
  both.F << a.F, (a.F.array() + static_cast<int>(n)).matrix();
  // Move a vertex of the second onto one of the first.
  Eigen::Index touching = 0;
  for (Eigen::Index v = 0; v < n; ++v)
    if (both.V(n + v, 0) < both.V(n + touching, 0)) touching = v;
  Eigen::Index target = 0;
  for (Eigen::Index v = 0; v < n; ++v)
    if (both.V(v, 0) > both.V(target, 0)) target = v;
  both.V.row(n + touching) = both.V.row(target);
  int merged = -1;
  const TriMesh welded = weld_boundary_vertices(both, &merged);
  EXPECT_EQ(merged, 0);
  EXPECT_TRUE(welded.V == both.V && welded.F == both.F);
  for (const MeshProblem& p : validate_mesh(both)) EXPECT_NE(p.kind, "coincident boundary vertices") << p.message;
}

TEST(ValidateMesh, ACutSurfaceWarnsOfEveryCoincidentPairInOneLine) {
  int copies = 0;
  const TriMesh cut = cut_plane(8, &copies);
  int warned = 0;
  for (const MeshProblem& p : validate_mesh(cut))
    if (p.kind == "coincident boundary vertices") {
      EXPECT_EQ(p.severity, MeshProblem::Severity::Warning);
      warned += p.count;
    }
  EXPECT_EQ(warned, copies);
  const std::vector<std::string> lines = require_valid_mesh(cut, "cut.obj");
  ASSERT_EQ(lines.size(), 1u); // one kind
  EXPECT_EQ(lines[0].rfind("cut.obj: vertices ", 0), 0u) << lines[0];
  EXPECT_NE(lines[0].find("(and " + std::to_string(copies - 1) + " more coincident boundary vertices)"),
            std::string::npos)
      << lines[0];
  EXPECT_TRUE(require_valid_mesh(make_plane(8), "plane.obj").empty());
}
