// Geometric texture through the shell map: analytic placement on a flat shell, continuity.
#include <gshell/deform/geometric_texture.h>
#include <gshell/error.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/shell/prism_tets.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <gtest/gtest.h>
#include "shell_fixtures.h"

#include <map>
#include <random>
#include <set>

namespace gshell {
namespace {

Shell flat_shell(const TriMesh& plane, double eta) { return test::lifted_shell(plane, eta); }

/// A tube shell whose top is pushed out unevenly, so prisms are all different and a mismatch of
/// cuts between neighbours would show.
Shell wavy_cylinder_shell(const TriMesh& cylinder) {
  Shell s;
  s.base = cylinder.V;
  s.top = cylinder.V;
  for (int i = 0; i < s.top.rows(); ++i) {
    const double r = 1.15 + 0.05 * std::sin(5 * s.top(i, 2)) * std::cos(3 * std::atan2(s.top(i, 1), s.top(i, 0)));
    s.top(i, 0) *= r;
    s.top(i, 1) *= r;
    s.top(i, 2) += 0.03 * std::cos(4 * std::atan2(s.top(i, 1), s.top(i, 0)));
  }
  s.F = cylinder.F;
  s.thickness = 0.15;
  return s;
}

TEST(GeometricTexture, FlatShellWithIdentityUVsGivesTheAnalyticPlacement) {
  const TriMesh plane = make_plane(6); // [-1,1]^2, UV = ((x+1)/2, (y+1)/2)
  const double eta = 0.2;
  const TriMesh tile = make_builtin_tile("builtin:bumps:7");
  const int U = 3, V = 2;
  const GeometricTexture tex = map_geometric_texture(flat_shell(plane, eta), plane, tile, U, V);
  EXPECT_EQ(tex.outside, 0);
  EXPECT_EQ(tex.reversed_faces, 0);
  ASSERT_EQ(tex.points, U * V * tile.num_vertices());
  ASSERT_EQ(static_cast<int>(tex.vertex_of_point.size()), tex.points);
  // The copies' 8 x 8 grids joined where they meet: one (7U + 1) x (7V + 1) grid.
  EXPECT_EQ(tex.mesh.num_vertices(), (7 * U + 1) * (7 * V + 1));
  EXPECT_EQ(tex.mesh.num_vertices(), tex.points - tex.joined);
  ASSERT_EQ(tex.mesh.num_faces(), U * V * tile.num_faces());
  int copy = 0;
  for (int j = 0; j < V; ++j)
    for (int i = 0; i < U; ++i, ++copy)
      for (int v = 0; v < tile.num_vertices(); ++v) {
        const Eigen::RowVector3d expected(2.0 * (i + tile.V(v, 0)) / U - 1.0, 2.0 * (j + tile.V(v, 1)) / V - 1.0,
                                          eta * tile.V(v, 2));
        EXPECT_LT((tex.mesh.V.row(tex.vertex_of_point[copy * tile.num_vertices() + v]) - expected).norm(), 1e-12);
      }
  for (int f = 0; f < tex.mesh.num_faces(); ++f)
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(tex.mesh.F(f, k),
                tex.vertex_of_point[tile.F(f % tile.num_faces(), k) + (f / tile.num_faces()) * tile.num_vertices()]);
}

/// Signed volume enclosed by the faces f0 .. f0 + count - 1 of `mesh` (positive: facing outwards).
double enclosed_volume(const TriMesh& mesh, int f0, int count) {
  double v = 0;
  for (int f = f0; f < f0 + count; ++f) {
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    v += a.dot(b.cross(c)) / 6;
  }
  return v;
}

// A UV layout mirrored (u -> 1 - u: every UV triangle wound against its face) maps texture space
// into the shell reversing orientation. A closed tile (a ball, facing outwards) still comes out
// facing outwards in every copy, its faces wound the other way round, and its texture
// coordinates follow its corners.
TEST(GeometricTexture, TilesOverAMirroredUvLayoutKeepFacingAsInTheTile) {
  TriMesh ball = make_sphere(1);
  ball.V = (ball.V * 0.3).array() + 0.5;
  ball.UV = ball.V.leftCols(2);
  ball.FUV = ball.F;
  ASSERT_GT(enclosed_volume(ball, 0, ball.num_faces()), 0);
  const TriMesh plane = make_plane(6);
  TriMesh mirrored = plane;
  mirrored.UV.col(0) = 1.0 - plane.UV.col(0).array();
  const Shell shell = flat_shell(plane, 0.2);
  const int U = 3, V = 2, nf = ball.num_faces();
  for (const TriMesh* layout : {&plane, static_cast<const TriMesh*>(&mirrored)}) {
    SCOPED_TRACE(layout == &plane ? "as made" : "mirrored");
    const GeometricTexture tex = map_geometric_texture(shell, *layout, ball, U, V);
    EXPECT_EQ(tex.reversed_faces, layout == &plane ? 0 : U * V * nf);
    EXPECT_EQ(tex.joined, 0); // closed copies have no border to join
    for (int c = 0; c < U * V; ++c) EXPECT_GT(enclosed_volume(tex.mesh, c * nf, nf), 0) << "copy " << c;
    ASSERT_TRUE(tex.mesh.has_uv());
    for (int f = 0; f < tex.mesh.num_faces(); ++f)
      for (int k = 0; k < 3; ++k) // each corner keeps its own texture coordinates
        EXPECT_EQ(tex.mesh.UV.row(tex.mesh.FUV(f, k)), ball.UV.row(tex.mesh.F(f, k) % ball.num_vertices()));
  }
}

/// Edges of `mesh` used by one face only.
int boundary_edges(const TriMesh& mesh) {
  std::map<std::pair<int, int>, int> uses;
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = mesh.F(f, k), b = mesh.F(f, (k + 1) % 3);
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  int once = 0;
  for (const auto& [edge, count] : uses) once += count == 1;
  return once;
}

// Tiles with matching borders over a torus close up across its UV seams, wherever the torus is:
// the seam's points map through different texture tets to one position up to a rounding that
// grows with the coordinates, and 1e5 from the origin it outgrew a tolerance of the output's size
// alone (holes and non-manifold vertices along the seams).
TEST(GeometricTexture, ATorusFarFromTheOriginStillClosesAcrossItsSeams) {
  const TriMesh torus = make_torus(24);
  const TriMesh tile = make_builtin_tile("builtin:bumps:8");
  for (double away : {0.0, 1e5, 1e7}) {
    SCOPED_TRACE(away);
    Shell shell;
    shell.base = torus.V.array() + away;
    shell.top = offset_top(shell.base, torus.F, 0.07);
    shell.F = torus.F;
    shell.thickness = 0.07;
    TriMesh layout = torus;
    layout.V = shell.base;
    const GeometricTexture tex = map_geometric_texture(shell, layout, tile, 3, 5);
    EXPECT_EQ(boundary_edges(tex.mesh), 0);
    EXPECT_EQ(tex.mesh.num_vertices(), 3 * 5 * 8 * 8); // every border point once
  }
}

// Only copies are joined, where they meet: points a tile itself keeps apart inside it (two
// triangles touching at a corner, a cut) stay apart, as `gshell info` shows them in the tile.
TEST(GeometricTexture, CoincidentPointsInsideATileStayApart) {
  TriMesh bowtie;
  bowtie.V.resize(6, 3);
  bowtie.V << 0.2, 0.2, 0.5, 0.5, 0.2, 0.5, 0.5, 0.5, 0.5, //
      0.5, 0.5, 0.5, 0.8, 0.5, 0.5, 0.8, 0.8, 0.5;
  bowtie.F.resize(2, 3);
  bowtie.F << 0, 1, 2, 3, 4, 5;
  const GeometricTexture tex = map_geometric_texture(flat_shell(make_plane(4), 0.2), make_plane(4), bowtie, 2, 2);
  EXPECT_EQ(tex.joined, 0);
  EXPECT_EQ(tex.mesh.num_vertices(), 4 * 6);
}

TEST(GeometricTexture, TextureSpaceTetsMatchTheShellTetsAndArePositive) {
  const TriMesh cylinder = make_cylinder(12);
  const TextureSpaceTets tex = texture_space_tets(cylinder.F, cylinder.UV, cylinder.FUV);
  const Eigen::MatrixXi shell_tets = build_prism_tets(cylinder.F, cylinder.num_vertices());
  const int n = cylinder.num_vertices(), k = static_cast<int>(cylinder.UV.rows());
  ASSERT_EQ(tex.T.rows(), shell_tets.rows());
  for (int t = 0; t < tex.T.rows(); ++t) {
    const int f = t / 3;
    for (int c = 0; c < 4; ++c) {
      // Same corner of the same prism: base/top level and the face corner agree.
      const bool top = shell_tets(t, c) >= n;
      EXPECT_EQ(tex.T(t, c) >= k, top);
      const int vertex = shell_tets(t, c) - (top ? n : 0), uv = tex.T(t, c) - (tex.T(t, c) >= k ? k : 0);
      int corner = -1;
      for (int q = 0; q < 3; ++q)
        if (cylinder.F(f, q) == vertex) corner = q;
      ASSERT_GE(corner, 0);
      EXPECT_EQ(cylinder.FUV(f, corner), uv);
    }
    // UVs are counter-clockwise like the faces, so texture-space tets are positive like the shell's.
    Eigen::Matrix3d D;
    for (int c = 0; c < 3; ++c) D.col(c) = (tex.X.row(tex.T(t, c + 1)) - tex.X.row(tex.T(t, 0))).transpose();
    EXPECT_GT(D.determinant(), 0);
  }
}

TEST(GeometricTexture, SharedTextureSpacePointsMapToOnePoint) {
  // Tile copies share their border points (x = 1 of one copy is x = 0 of the next, and across the
  // cylinder's seam u = 1 is u = 0): each shared point must map to one place, whichever prism it
  // was located in.
  const TriMesh cylinder = make_cylinder(16);
  const Shell shell = wavy_cylinder_shell(cylinder);
  const TriMesh tile = make_builtin_tile("builtin:bumps:5");
  const int U = 4, V = 3, nv = tile.num_vertices();
  const GeometricTexture tex = map_geometric_texture(shell, cylinder, tile, U, V);
  EXPECT_EQ(tex.outside, 0);
  int checked = 0;
  for (int j = 0; j < V; ++j)
    for (int i = 0; i < U; ++i)
      for (int v = 0; v < nv; ++v) {
        if (tile.V(v, 0) != 1.0) continue;
        const int right = ((i + 1) % U) + j * U; // wraps around the seam
        const int w = v - 5;                     // same row, x = 0 (grid of 6 x 6 vertices)
        ASSERT_EQ(tile.V(w, 0), 0.0);
        ASSERT_EQ(tile.V(w, 1), tile.V(v, 1));
        const int p = (i + j * U) * nv + v, q = right * nv + w;
        const Eigen::RowVector3d a = tex.mesh.V.row(tex.vertex_of_point[p]), b = tex.mesh.V.row(tex.vertex_of_point[q]);
        EXPECT_LT((a - b).norm(), 1e-12) << "copy " << i << "," << j << " vertex " << v;
        ++checked;
      }
  EXPECT_EQ(checked, U * V * 6);
}

TEST(GeometricTexture, MapIsContinuousAcrossPrismBorders) {
  // Points on side quads shared by two prisms, approached from either prism, map to the same
  // point: both prisms cut the quad along the same diagonal (min-index rule).
  const TriMesh cylinder = make_cylinder(12);
  const Shell shell = wavy_cylinder_shell(cylinder);
  // Interior UV edges: pairs of faces sharing two UV ids.
  std::map<std::pair<int, int>, std::vector<int>> edge_faces;
  for (int f = 0; f < cylinder.FUV.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int a = cylinder.FUV(f, c), b = cylinder.FUV(f, (c + 1) % 3);
      edge_faces[{std::min(a, b), std::max(a, b)}].push_back(f);
    }
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(0.05, 0.95);
  TriMesh probes; // one "tile" of 2 points per shared edge, placed in texture space directly
  std::vector<Eigen::RowVector3d> points;
  const double eps = 1e-9;
  for (const auto& [edge, faces] : edge_faces) {
    if (faces.size() != 2) continue;
    const Eigen::RowVector2d a = cylinder.UV.row(edge.first), b = cylinder.UV.row(edge.second);
    const Eigen::RowVector2d p = a + unit(rng) * (b - a);
    const double h = unit(rng);
    for (int f : faces) {
      Eigen::RowVector2d centroid = Eigen::RowVector2d::Zero();
      for (int c = 0; c < 3; ++c) centroid += cylinder.UV.row(cylinder.FUV(f, c)) / 3.0;
      const Eigen::RowVector2d q = p + eps * (centroid - p).normalized();
      points.emplace_back(q.x(), q.y(), h);
    }
  }
  probes.V.resize(static_cast<int>(points.size()), 3);
  for (int i = 0; i < probes.V.rows(); ++i) probes.V.row(i) = points[i];
  probes.F.resize(1, 3);
  probes.F << 0, 1, 2;
  // The cylinder's UVs span exactly [0,1]^2, so one tile is texture space itself.
  const GeometricTexture tex = map_geometric_texture(shell, cylinder, probes, 1, 1);
  EXPECT_EQ(tex.outside, 0);
  ASSERT_GT(probes.V.rows(), 100);
  for (int i = 0; i + 1 < probes.V.rows(); i += 2)
    EXPECT_LT((tex.mesh.V.row(tex.vertex_of_point[i]) - tex.mesh.V.row(tex.vertex_of_point[i + 1])).norm(), 1e-6)
        << "probe pair " << i / 2;
}

TEST(GeometricTexture, HeightZeroLiesOnTheBaseAndOneOnTheTop) {
  // On the flat shell the analytic test covers this; here on a curved, uneven shell the mapped
  // vertices of a UV-grid tile at h = 0 / h = 1 are exactly the base / top vertices.
  const TriMesh cylinder = make_cylinder(8);
  const Shell shell = wavy_cylinder_shell(cylinder);
  TriMesh probes;
  const int k = static_cast<int>(cylinder.UV.rows());
  probes.V.resize(2 * k, 3);
  probes.V << cylinder.UV, Eigen::VectorXd::Zero(k), cylinder.UV, Eigen::VectorXd::Ones(k);
  probes.F.resize(1, 3);
  probes.F << 0, 1, 2;
  const GeometricTexture tex = map_geometric_texture(shell, cylinder, probes, 1, 1);
  EXPECT_EQ(tex.outside, 0);
  for (int f = 0; f < cylinder.F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int uv = cylinder.FUV(f, c), v = cylinder.F(f, c);
      EXPECT_LT((tex.mesh.V.row(tex.vertex_of_point[uv]) - shell.base.row(v)).norm(), 1e-12);
      EXPECT_LT((tex.mesh.V.row(tex.vertex_of_point[k + uv]) - shell.top.row(v)).norm(), 1e-12);
    }
}

TEST(GeometricTexture, BuiltinTileAndErrors) {
  const TriMesh tile = make_builtin_tile("builtin:bumps");
  EXPECT_EQ(tile.num_vertices(), 17 * 17);
  EXPECT_GE(tile.V.minCoeff(), 0.0);
  EXPECT_LE(tile.V.maxCoeff(), 1.0);
  EXPECT_THROW(make_builtin_tile("builtin:bumps:0"), InputError);
  EXPECT_THROW(make_builtin_tile("builtin:bumps:x"), InputError);
  EXPECT_THROW(make_builtin_tile("builtin:bumpsy"), InputError);

  TriMesh plane = make_plane(4);
  const Shell shell = flat_shell(plane, 0.1);
  EXPECT_THROW(map_geometric_texture(shell, plane, tile, 0, 1), InputError);
  TriMesh bad_tile = tile;
  bad_tile.V(3, 1) = std::nan("");
  EXPECT_THROW(map_geometric_texture(shell, plane, bad_tile, 1, 1), InputError);
  plane.UV.resize(0, 2);
  plane.FUV.resize(0, 3);
  EXPECT_THROW(map_geometric_texture(shell, plane, tile, 1, 1), InputError);
}

} // namespace
} // namespace gshell
