// The intersection counter against hand-built configurations with known answers, a brute-force
// all-pairs check on a random soup, and clean / broken closed meshes.
#include <gshell/error.h>
#include <gshell/quality/triangle_intersections.h>

#include "quality_test_meshes.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Intersections_3/Triangle_3_Triangle_3.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>

namespace gshell {
namespace {

using Tri = std::array<Eigen::Vector3d, 3>;

// Two triangles as two separate one-face meshes, and as one two-face mesh with distinct ids.
int count_between(const Tri& a, const Tri& b) {
  Eigen::MatrixXd V1(3, 3), V2(3, 3);
  for (int k = 0; k < 3; ++k) {
    V1.row(k) = a[k].transpose();
    V2.row(k) = b[k].transpose();
  }
  const Eigen::MatrixXi F = (Eigen::MatrixXi(1, 3) << 0, 1, 2).finished();
  return count_intersections_between(V1, F, V2, F);
}

int count_in_one_mesh(const Tri& a, const Tri& b) {
  Eigen::MatrixXd V(6, 3);
  for (int k = 0; k < 3; ++k) {
    V.row(k) = a[k].transpose();
    V.row(3 + k) = b[k].transpose();
  }
  const Eigen::MatrixXi F = (Eigen::MatrixXi(2, 3) << 0, 1, 2, 3, 4, 5).finished();
  return count_self_intersections(V, F);
}

void expect_pair_count(const Tri& a, const Tri& b, int expected) {
  EXPECT_EQ(count_between(a, b), expected);
  EXPECT_EQ(count_between(b, a), expected);
  EXPECT_EQ(count_in_one_mesh(a, b), expected);
}

const Tri kFloor = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 2, 0)};

TEST(TriangleIntersections, CrossingTrianglesIntersect) {
  // Upright triangle in x = 0.5 whose slice at z = 0 (y in [-1, 0.5]) overlaps the floor's
  // slice (y in [0, 1.5]); neither contains the other's crossing segment.
  const Tri upright = {Eigen::Vector3d(0.5, 0.5, -1), Eigen::Vector3d(0.5, 0.5, 1),
                       Eigen::Vector3d(0.5, -1, 0)};
  expect_pair_count(kFloor, upright, 1);
}

TEST(TriangleIntersections, PiercingTriangleIntersects) {
  const Tri needle = {Eigen::Vector3d(0.5, 0.5, -1), Eigen::Vector3d(0.6, 0.5, 1),
                      Eigen::Vector3d(0.5, 0.6, 1)};
  expect_pair_count(kFloor, needle, 1);
}

TEST(TriangleIntersections, CoplanarOverlapIntersects) {
  const Tri shifted = {Eigen::Vector3d(0.5, 0.5, 0), Eigen::Vector3d(2.5, 0.5, 0),
                       Eigen::Vector3d(0.5, 2.5, 0)};
  expect_pair_count(kFloor, shifted, 1);
  const Tri inside = {Eigen::Vector3d(0.1, 0.1, 0), Eigen::Vector3d(0.5, 0.1, 0),
                      Eigen::Vector3d(0.1, 0.5, 0)};
  expect_pair_count(kFloor, inside, 1);
}

TEST(TriangleIntersections, TouchingCountsAsIntersecting) {
  // Chosen convention: faces are closed sets, so a single common point is an intersection.
  const Tri corner_on_interior = {Eigen::Vector3d(0.5, 0.5, 0), Eigen::Vector3d(1, 1, 1),
                                  Eigen::Vector3d(0, 1, 1)};
  expect_pair_count(kFloor, corner_on_interior, 1);
  // Same position as a floor corner but a different vertex id: still a touching pair.
  const Tri corner_on_corner = {Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(3, 1, 1),
                                Eigen::Vector3d(3, -1, 1)};
  expect_pair_count(kFloor, corner_on_corner, 1);
  const Tri edge_on_edge = {Eigen::Vector3d(0.5, 0, 0), Eigen::Vector3d(1.5, 0, 0),
                            Eigen::Vector3d(1, -1, 0)};
  expect_pair_count(kFloor, edge_on_edge, 1);
}

TEST(TriangleIntersections, SeparatedTrianglesDoNotIntersect) {
  const Tri above = {Eigen::Vector3d(0, 0, 1e-9), Eigen::Vector3d(2, 0, 1e-9),
                     Eigen::Vector3d(0, 2, 1e-9)};
  expect_pair_count(kFloor, above, 0);
  // Boxes overlap, triangles do not: beyond the floor's hypotenuse.
  const Tri beside = {Eigen::Vector3d(1.6, 1.6, -1), Eigen::Vector3d(1.6, 1.6, 1),
                      Eigen::Vector3d(1.9, 1.9, 0)};
  expect_pair_count(kFloor, beside, 0);
}

TEST(TriangleIntersections, NeighboursSharingAVertexOrEdgeAreNotCounted) {
  // Folded flat onto each other across the shared edge 0-1: the faces overlap but are neighbours.
  Eigen::MatrixXd V(5, 3);
  V << 0, 0, 0, 2, 0, 0, 0, 2, 0, 1, 1, 0, 1, -1, 5;
  const Eigen::MatrixXi shares_edge = (Eigen::MatrixXi(2, 3) << 0, 1, 2, 1, 0, 3).finished();
  EXPECT_EQ(count_self_intersections(V, shares_edge), 0);
  // Sharing only vertex 0 while piercing: still neighbours.
  const Eigen::MatrixXi shares_vertex = (Eigen::MatrixXi(2, 3) << 0, 1, 2, 0, 3, 4).finished();
  EXPECT_EQ(count_self_intersections(V, shares_vertex), 0);
}

TEST(TriangleIntersections, DegenerateFacesAreTheirSegmentOrPoint) {
  // Collinear corners: the segment from (0.5,0.5,-1) to (0.5,0.5,1) pierces the floor.
  const Tri needle = {Eigen::Vector3d(0.5, 0.5, -1), Eigen::Vector3d(0.5, 0.5, 1),
                      Eigen::Vector3d(0.5, 0.5, 0.25)};
  expect_pair_count(kFloor, needle, 1);
  const Tri needle_beside = {Eigen::Vector3d(3, 3, -1), Eigen::Vector3d(3, 3, 1),
                             Eigen::Vector3d(3, 3, 0)};
  expect_pair_count(kFloor, needle_beside, 0);
  // All corners equal: a point on the floor, and a point above it.
  const Tri dot_on = {Eigen::Vector3d(1, 0.5, 0), Eigen::Vector3d(1, 0.5, 0),
                      Eigen::Vector3d(1, 0.5, 0)};
  expect_pair_count(kFloor, dot_on, 1);
  const Tri dot_off = {Eigen::Vector3d(1, 0.5, 0.1), Eigen::Vector3d(1, 0.5, 0.1),
                       Eigen::Vector3d(1, 0.5, 0.1)};
  expect_pair_count(kFloor, dot_off, 0);
  // Degenerate against degenerate: crossing segments, equal points.
  const Tri cross = {Eigen::Vector3d(0, 0.5, 0.25), Eigen::Vector3d(1, 0.5, 0.25),
                     Eigen::Vector3d(1, 0.5, 0.25)};
  expect_pair_count(needle, cross, 1);
  expect_pair_count(dot_on, dot_on, 1);
  expect_pair_count(dot_on, dot_off, 0);
}

TEST(TriangleIntersections, RandomSoupMatchesBruteForce) {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> centre(0, 4), offset(-0.4, 0.4);
  const int m = 400;
  Eigen::MatrixXd V(3 * m, 3);
  Eigen::MatrixXi F(m, 3);
  for (int f = 0; f < m; ++f) {
    const Eigen::Vector3d c(centre(rng), centre(rng), centre(rng));
    for (int k = 0; k < 3; ++k) {
      V.row(3 * f + k) = (c + Eigen::Vector3d(offset(rng), offset(rng), offset(rng))).transpose();
      F(f, k) = 3 * f + k;
    }
  }
  auto triangle = [&](int f) {
    auto p = [&](int k) { return K::Point_3(V(F(f, k), 0), V(F(f, k), 1), V(F(f, k), 2)); };
    return K::Triangle_3(p(0), p(1), p(2));
  };
  std::vector<std::pair<int, int>> brute;
  for (int f = 0; f < m; ++f)
    for (int g = f + 1; g < m; ++g)
      if (CGAL::do_intersect(triangle(f), triangle(g))) brute.emplace_back(f, g);
  ASSERT_GT(brute.size(), 10u); // the soup is dense enough to test something
  EXPECT_EQ(self_intersecting_pairs(V, F), brute);
  EXPECT_EQ(count_self_intersections(V, F), static_cast<int>(brute.size()));

  // Split the soup into two meshes: the pairs between them are the brute pairs across the split.
  const int half = m / 2;
  const Eigen::MatrixXd V1 = V.topRows(3 * half), V2 = V.bottomRows(3 * (m - half));
  const Eigen::MatrixXi F1 = F.topRows(half);
  const Eigen::MatrixXi F2 = (F.bottomRows(m - half).array() - 3 * half).matrix();
  std::vector<std::pair<int, int>> across;
  for (const auto& [f, g] : brute)
    if (f < half && g >= half) across.emplace_back(f, g - half);
  EXPECT_EQ(intersecting_pairs_between(V1, F1, V2, F2), across);
}

TEST(TriangleIntersections, StackOfNearCoincidentFaces) {
  // 60 parallel copies of one triangle 1e-9 apart (same centroid cell, so the hierarchy has to
  // split equal sort keys), pierced by one needle through all of them.
  const int copies = 60;
  Eigen::MatrixXd V(3 * copies + 3, 3);
  Eigen::MatrixXi F(copies + 1, 3);
  for (int c = 0; c < copies; ++c) {
    const double z = 1e-9 * c;
    V.row(3 * c) << 0, 0, z;
    V.row(3 * c + 1) << 2, 0, z;
    V.row(3 * c + 2) << 0, 2, z;
    F.row(c) << 3 * c, 3 * c + 1, 3 * c + 2;
  }
  V.row(3 * copies) << 0.5, 0.5, -1;
  V.row(3 * copies + 1) << 0.6, 0.5, 1;
  V.row(3 * copies + 2) << 0.5, 0.6, 1;
  F.row(copies) << 3 * copies, 3 * copies + 1, 3 * copies + 2;
  const auto pairs = self_intersecting_pairs(V, F);
  ASSERT_EQ(pairs.size(), static_cast<std::size_t>(copies));
  for (int c = 0; c < copies; ++c) EXPECT_EQ(pairs[c], std::make_pair(c, copies));
}

TEST(TriangleIntersections, CleanSphereHasNone) {
  const auto sphere = test::icosphere(4);
  EXPECT_EQ(count_self_intersections(sphere.V, sphere.F), 0);
}

TEST(TriangleIntersections, VertexPushedThroughTheSphereIsFound) {
  auto sphere = test::icosphere(3);
  // Vertex 0 goes through the centre and out of the far side: its fan pierces the far faces.
  sphere.V.row(0) *= -1.3;
  const auto pairs = self_intersecting_pairs(sphere.V, sphere.F);
  EXPECT_GT(pairs.size(), 0u);
  for (const auto& [f, g] : pairs) {
    EXPECT_LT(f, g);
    const bool f_moved = (sphere.F.row(f).array() == 0).any();
    const bool g_moved = (sphere.F.row(g).array() == 0).any();
    EXPECT_TRUE(f_moved || g_moved) << "pair " << f << "," << g << " involves no moved face";
  }
}

TEST(TriangleIntersections, ConcentricSpheresHaveNoneBetween) {
  const auto inner = test::icosphere(3, 1.0), outer = test::icosphere(3, 1.05);
  EXPECT_EQ(count_intersections_between(inner.V, inner.F, outer.V, outer.F), 0);
  EXPECT_EQ(count_self_intersections(outer.V, outer.F), 0);
}

TEST(TriangleIntersections, InnerSpherePokingOutIntersects) {
  const auto outer = test::icosphere(3, 1.05);
  // The inner sphere moved by 0.1 reaches x = 1.1, through the outer one.
  const auto moved_inner = test::icosphere(3, 1.0, Eigen::Vector3d(0.1, 0, 0));
  EXPECT_GT(count_intersections_between(moved_inner.V, moved_inner.F, outer.V, outer.F), 0);
  // A bigger inner sphere, differently faceted, crossing the outer one where its facets dip.
  const auto bigger_inner = test::icosphere(2, 1.06);
  EXPECT_GT(count_intersections_between(bigger_inner.V, bigger_inner.F, outer.V, outer.F), 0);
}

TEST(TriangleIntersections, EmptyMeshesAndBadInput) {
  const Eigen::MatrixXd V0(0, 3);
  const Eigen::MatrixXi F0(0, 3);
  EXPECT_EQ(count_self_intersections(V0, F0), 0);
  const auto sphere = test::icosphere(1);
  EXPECT_EQ(count_intersections_between(sphere.V, sphere.F, V0, F0), 0);

  Eigen::MatrixXi bad = sphere.F;
  bad(3, 1) = static_cast<int>(sphere.V.rows());
  EXPECT_THROW(count_self_intersections(sphere.V, bad), InputError);
  EXPECT_THROW(count_intersections_between(sphere.V, sphere.F, sphere.V, bad), InputError);
  Eigen::MatrixXd nan = sphere.V;
  nan(2, 2) = std::nan("");
  EXPECT_THROW(count_self_intersections(nan, sphere.F), InputError);
}

} // namespace
} // namespace gshell
