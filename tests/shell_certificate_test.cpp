// The exact shell certificate (quality/shell_certificate.h) on hand-built shells with known
// answers, and the adjacency-aware pair test against an independent brute force that computes
// every intersection exactly (CGAL's exact constructions) and checks where it lies.
#include <gshell/error.h>
#include <gshell/deform/synthetic_motion.h>
#include <gshell/quality/certificate_report.h>
#include <gshell/quality/shell_boundary.h>
#include <gshell/quality/shell_certificate.h>
#include <gshell/quality/shell_metrics.h>
#include <gshell/quality/triangle_intersections.h>
#include <gshell/shell/generate_report.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/shell/prism_tets.h>

#include "core_test_meshes.h"
#include "shell_fixtures.h"

#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Intersections_3/Triangle_3_Triangle_3.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <optional>
#include <random>
#include <set>

namespace gshell {
namespace {

using test::SimpleMesh;
using Pairs = std::vector<std::pair<int, int>>;

// Offset shell: top = base + eta * vertex normal.
ShellCertificate certify_offset(const SimpleMesh& m, double eta) {
  return certify_shell(m.V, offset_top(m.V, m.F, eta), m.F);
}

void expect_clean(const ShellCertificate& c) {
  EXPECT_EQ(c.inverted_tets, 0);
  EXPECT_EQ(c.top_self_intersections, 0);
  EXPECT_EQ(c.top_base_intersections, 0);
  EXPECT_EQ(c.wall_intersections, 0);
  EXPECT_EQ(c.base_self_intersections, 0);
  EXPECT_TRUE(c.intersections.empty());
  EXPECT_TRUE(c.inverted_tet_ids.empty());
  EXPECT_TRUE(c.valid());
}

// Pairs of one kind, as (row a, row b).
Pairs pairs_of(const ShellCertificate& c, IntersectionKind kind) {
  Pairs out;
  for (const BoundaryIntersection& p : c.intersections)
    if (p.kind == kind) out.emplace_back(p.a, p.b);
  return out;
}

// Tets (rows of build_prism_tets) that have both base vertex v and top vertex n + v.
std::vector<int> tets_through_vertical_edge(const Eigen::MatrixXi& F, int n, int v) {
  const Eigen::MatrixXi T = build_prism_tets(F, n);
  std::vector<int> ids;
  for (int t = 0; t < T.rows(); ++t)
    if ((T.row(t).array() == v).any() && (T.row(t).array() == n + v).any()) ids.push_back(t);
  return ids;
}

// The base lifted along +z: the top of a flat shell over a plane in z = 0.
Eigen::MatrixXd lifted(const Eigen::MatrixXd& base, double eta) {
  Eigen::MatrixXd top = base;
  top.col(2).array() += eta;
  return top;
}

// A vertex of the grid plane (test::plane(res)) at grid position (i, j).
int grid_vertex(int res, int i, int j) { return i * (res + 1) + j; }

TEST(ShellCertificate, ValidOffsetShellsAreClean) {
  expect_clean(certify_offset(test::icosphere(3), 0.05));
  expect_clean(certify_offset(test::torus(32, 16), 0.1));
  expect_clean(certify_offset(test::plane(8, 0.2), 0.05));
  expect_clean(certify_offset(test::permuted(test::plane(8, 0.2), 3), 0.05));
  const ShellCertificate c = certify_offset(test::icosphere(2), 0.05);
  EXPECT_TRUE(c.exact);
  EXPECT_TRUE(c.intersections_tested());
}

TEST(ShellCertificate, TopVertexBelowTheBaseInvertsItsTetsAndCrossesTheBase) {
  const SimpleMesh m = test::icosphere(3);
  const int n = static_cast<int>(m.V.rows()), v = 17;
  Eigen::MatrixXd top = offset_top(m.V, m.F, 0.05);
  top.row(v) = 0.97 * m.V.row(v); // pushed below the base
  const ShellCertificate c = certify_shell(m.V, top, m.F);
  EXPECT_GT(c.inverted_tets, 0);
  EXPECT_GT(c.top_base_intersections, 0);
  EXPECT_FALSE(c.valid());
  const Eigen::MatrixXi T = build_prism_tets(m.F, n);
  for (int t : c.inverted_tet_ids) EXPECT_TRUE((T.row(t).array() == n + v).any()) << "tet " << t;
  for (const auto& [a, b] : pairs_of(c, IntersectionKind::TopBase)) {
    ASSERT_LT(a, m.F.rows()); // base rows come first
    EXPECT_TRUE((m.F.row(b - m.F.rows()).array() == v).any()) << "top face " << b - m.F.rows();
  }
}

TEST(ShellCertificate, ZeroVolumeCountsAsInvertedExactly) {
  // Flat plane shell, top vertex v lowered onto (and to within 1e-300 of) its base vertex: every
  // tet through the vertical edge (v, n + v) becomes flat at height 0, is positive at 1e-300.
  const int res = 4;
  const SimpleMesh m = test::plane(res);
  const int n = static_cast<int>(m.V.rows()), v = grid_vertex(res, 2, 2);
  const double eta = 0.25;
  Eigen::MatrixXd top = lifted(m.V, eta);

  top(v, 2) = 1e-300;
  expect_clean(certify_shell(m.V, top, m.F));

  top(v, 2) = 0;
  const ShellCertificate flat = certify_shell(m.V, top, m.F);
  EXPECT_EQ(flat.inverted_tet_ids, tets_through_vertical_edge(m.F, n, v));
  EXPECT_GT(flat.top_base_intersections, 0); // the top touches the base at v
  EXPECT_FALSE(flat.valid());
}

TEST(ShellCertificate, DegenerateTopTriangleIsReportedAsAFlatTet) {
  const int res = 4;
  const SimpleMesh m = test::plane(res);
  Eigen::MatrixXd top = lifted(m.V, 0.25);
  const int f = 10, n = static_cast<int>(m.V.rows());
  // Corner 2 of face f's top onto the midpoint of its other two corners (exact: grid coordinates
  // are multiples of 0.5).
  top.row(m.F(f, 2)) = 0.5 * (top.row(m.F(f, 0)) + top.row(m.F(f, 1)));
  const ShellCertificate c = certify_shell(m.V, top, m.F);
  // The prism's third tet (base corner + the whole top triangle) has no volume.
  EXPECT_TRUE(std::count(c.inverted_tet_ids.begin(), c.inverted_tet_ids.end(), 3 * f + 2)) << n;
  EXPECT_FALSE(c.valid());
}

TEST(ShellCertificate, TetSignsAreExactNearZero) {
  // One prism whose top corners lie on (or a rounding error off) planes through base corners:
  // the tets' orientations are zero or tiny, and must match CGAL's exact orientation.
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> coordinate(-1, 1), weight(-0.5, 1.5);
  const Eigen::MatrixXi F = (Eigen::MatrixXi(1, 3) << 0, 1, 2).finished();
  const auto tets = prism_corner_tets(0, 1, 2);
  int zero = 0, inverted = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    // Odd trials: random doubles, each top corner in the base plane up to the rounding of its
    // construction. Even trials: small dyadic numbers, so that the construction is exact and the
    // top corners lie exactly in the base plane.
    const bool exact = trial % 2 == 0;
    std::uniform_int_distribution<int> small(-8, 8), quarter(-2, 6);
    const double scale = std::pow(2.0, trial % 7 * 9 - 27);
    Eigen::MatrixXd base(3, 3), top(3, 3);
    for (Eigen::Index i = 0; i < base.size(); ++i) base(i) = (exact ? small(rng) : coordinate(rng)) * scale;
    for (int k = 0; k < 3; ++k) {
      const Eigen::RowVector3d a = base.row(k), b = base.row((k + 1) % 3), c = base.row((k + 2) % 3);
      const double u = exact ? quarter(rng) / 4.0 : weight(rng), v = exact ? quarter(rng) / 4.0 : weight(rng);
      top.row(k) = a + u * (b - a) + v * (c - a);
    }
    if (trial % 5 == 0) top(trial % 3, 2) += base(0, 2) * 1e-300;
    const ShellCertificate c = certify_shell(base, top, F, CertifyOptions{false, false});
    auto corner = [&](int j) {
      const Eigen::RowVector3d p = j < 3 ? base.row(j) : top.row(j - 3);
      return K::Point_3(p[0], p[1], p[2]);
    };
    std::vector<int> expected;
    for (int t = 0; t < 3; ++t) {
      const CGAL::Orientation o =
          CGAL::orientation(corner(tets[t][0]), corner(tets[t][1]), corner(tets[t][2]), corner(tets[t][3]));
      if (o != CGAL::POSITIVE) expected.push_back(t);
      zero += o == CGAL::ZERO;
    }
    EXPECT_EQ(c.inverted_tet_ids, expected) << "trial " << trial;
    inverted += static_cast<int>(expected.size());
  }
  EXPECT_GT(zero, 100); // exact zeros do occur (tets through a base triangle's plane)
  EXPECT_GT(inverted, 1000);
}

// Two faces, given by their base and top corners; the base lies flat at z = 0.
struct TwoFaces {
  Eigen::MatrixXd base, top;
  Eigen::MatrixXi F;
};

// Faces F over base corners V (rows: x y z), the top lifted by 1.
TwoFaces lifted_faces(std::initializer_list<double> V, std::initializer_list<int> F) {
  TwoFaces t;
  t.base.resize(static_cast<Eigen::Index>(V.size() / 3), 3);
  std::copy(V.begin(), V.end(), t.base.reshaped<Eigen::RowMajor>().begin());
  t.top = lifted(t.base, 1);
  t.F.resize(static_cast<Eigen::Index>(F.size() / 3), 3);
  std::copy(F.begin(), F.end(), t.F.reshaped<Eigen::RowMajor>().begin());
  return t;
}

// Faces (0, 1, 2) and (1, 0, 3) share the edge 0-1: r = vertex 2 on one side, s = 3 on the other.
TwoFaces edge_neighbours() { return lifted_faces({0, 0, 0, 1, 0, 0, 0.5, 1, 0, 0.5, -1, 0}, {0, 1, 2, 1, 0, 3}); }

TEST(ShellCertificate, EdgeNeighboursFoldedFlatOntoEachOtherAreCounted) {
  TwoFaces t = edge_neighbours();
  const int m = 2;
  EXPECT_EQ(certify_shell(t.base, t.top, t.F).top_self_intersections, 0);
  t.top.row(3) << 0.5, 0.5, 1; // s onto r's side, in the same plane: the tops overlap
  const ShellCertificate folded = certify_shell(t.base, t.top, t.F);
  EXPECT_EQ(folded.top_self_intersections, 1);
  EXPECT_EQ(pairs_of(folded, IntersectionKind::TopTop), Pairs({{m, m + 1}}));
  EXPECT_EQ(count_self_intersections(t.top, t.F), 0); // today's counter skips neighbours
  t.top.row(3) << 0.5, 0.5, 1.3; // folded over, but out of the plane: they meet on the edge only
  EXPECT_EQ(certify_shell(t.base, t.top, t.F).top_self_intersections, 0);
  t.top.row(3) << 0.5, 2, 1; // in the plane, on r's side, beyond r: overlap again
  EXPECT_EQ(certify_shell(t.base, t.top, t.F).top_self_intersections, 1);
}

// Faces (0, 1, 2) and (0, 3, 4) share vertex 0 only.
TwoFaces vertex_neighbours() {
  return lifted_faces({0, 0, 0, 1, 0, 0, 0, 1, 0, -1, 0, 0, 0, -1, 0}, {0, 1, 2, 0, 3, 4});
}

TEST(ShellCertificate, VertexNeighboursMayMeetOnlyAtTheirVertex) {
  TwoFaces t = vertex_neighbours();
  const int m = 2;
  EXPECT_EQ(certify_shell(t.base, t.top, t.F).top_self_intersections, 0);
  // Corner 3 swung up through the other top triangle: they cross away from vertex 0.
  t.top.row(3) << 0.3, 0.3, 2;
  t.top.row(4) << 0.3, 0.3, 0.5;
  const ShellCertificate crossing = certify_shell(t.base, t.top, t.F);
  EXPECT_EQ(pairs_of(crossing, IntersectionKind::TopTop), Pairs({{m, m + 1}}));
  EXPECT_EQ(count_self_intersections(t.top, t.F), 0); // today's counter skips neighbours
  // Corner 4 lowered into the plane of the first top, outside it: they touch at vertex 0 only.
  t.top.row(3) << -1, 0, 1.5;
  t.top.row(4) << -1, -1, 1;
  EXPECT_EQ(certify_shell(t.base, t.top, t.F).top_self_intersections, 0);
  // The second top folded flat into the first one's angle: coplanar overlap near vertex 0.
  t.top.row(3) << 0.5, 0.1, 1;
  t.top.row(4) << 0.1, 0.5, 1;
  EXPECT_EQ(certify_shell(t.base, t.top, t.F).top_self_intersections, 1);
  // Along the first top's edge 0-1 from vertex 0: they share a segment beyond the vertex.
  t.top.row(3) << 0.5, 0, 1;
  t.top.row(4) << 0.5, -1, 1;
  EXPECT_EQ(certify_shell(t.base, t.top, t.F).top_self_intersections, 1);
}

TEST(ShellCertificate, NonAdjacentTrianglesTouchingAtAPointAreCounted) {
  TwoFaces t = lifted_faces({0, 0, 0, 1, 0, 0, 0, 1, 0, 2, 0, 0, 3, 0, 0, 2, 1, 0}, {0, 1, 2, 3, 4, 5});
  EXPECT_EQ(certify_shell(t.base, t.top, t.F).top_self_intersections, 0);
  t.top.row(3) << 0.25, 0.25, 1; // a corner of the second top on the first one's interior
  const ShellCertificate c = certify_shell(t.base, t.top, t.F);
  EXPECT_EQ(pairs_of(c, IntersectionKind::TopTop), Pairs({{2, 3}}));
  EXPECT_EQ(count_self_intersections(t.top, t.F), 1); // today's counter agrees on non-neighbours
}

TEST(ShellCertificate, TopThroughTheBaseIsATopBasePair) {
  TwoFaces t = lifted_faces({0, 0, 0, 1, 0, 0, 0, 1, 0}, {0, 1, 2});
  expect_clean(certify_shell(t.base, t.top, t.F));
  t.top.row(2) << 0.2, 0.2, -1; // one top corner through the base triangle
  const ShellCertificate c = certify_shell(t.base, t.top, t.F);
  EXPECT_EQ(pairs_of(c, IntersectionKind::TopBase), Pairs({{0, 1}}));
  EXPECT_EQ(c.top_base_intersections, 1);
}

TEST(ShellCertificate, TopPushedAcrossASideWallIsAWallIntersection) {
  const int res = 4;
  const SimpleMesh m = test::plane(res);
  Eigen::MatrixXd top = lifted(m.V, 0.25);
  // The vertex next to the x = -1 border, its top pushed out beyond the wall at half height.
  const int v = grid_vertex(res, 1, 2);
  top.row(v) << -1.5, m.V(v, 1), 0.125;
  const ShellCertificate c = certify_shell(m.V, top, m.F);
  EXPECT_GT(c.wall_intersections, 0);
  EXPECT_FALSE(c.valid());
  const int faces = static_cast<int>(m.F.rows());
  for (const auto& [a, b] : pairs_of(c, IntersectionKind::Wall)) EXPECT_GE(b, 2 * faces) << a; // b is the wall
  // The same shell without the push has walls that meet only along their shared edges.
  top.row(v) = m.V.row(v);
  top(v, 2) += 0.25;
  expect_clean(certify_shell(m.V, top, m.F));
}

TEST(ShellCertificate, BaseSelfIntersectionsAreCountedApart) {
  SimpleMesh m = test::icosphere(3);
  m.V.row(0) *= -1.3; // through the centre and out of the far side
  const Eigen::MatrixXd top = 1.01 * m.V;
  const ShellCertificate c = certify_shell(m.V, top, m.F);
  const Pairs base_pairs = surface_self_intersections(m.V, m.F);
  ASSERT_GT(base_pairs.size(), 0u);
  EXPECT_EQ(pairs_of(c, IntersectionKind::BaseBase), base_pairs); // base rows are face ids
  EXPECT_EQ(c.base_self_intersections, static_cast<int>(base_pairs.size()));
  EXPECT_FALSE(c.valid()); // no shell over a base that crosses itself is an embedding
  // Every pair today's counter finds is among them (it skips neighbours).
  for (const auto& p : self_intersecting_pairs(m.V, m.F))
    EXPECT_TRUE(std::binary_search(base_pairs.begin(), base_pairs.end(), p)) << p.first << "," << p.second;
  CertifyOptions skip;
  skip.base_self_intersections = false;
  const ShellCertificate without = certify_shell(m.V, top, m.F, skip);
  EXPECT_EQ(without.base_self_intersections, -1);
  EXPECT_TRUE(pairs_of(without, IntersectionKind::BaseBase).empty());
  EXPECT_EQ(without.top_self_intersections, c.top_self_intersections);
}

TEST(ShellCertificate, AgreesWithTodaysCountersOnNonAdjacentPairs) {
  // A torus shell thicker than its tube: the top crosses itself in the hole; a sphere shell whose
  // top is shaken: crossings everywhere.
  std::vector<std::pair<SimpleMesh, Eigen::MatrixXd>> shells;
  const SimpleMesh torus = test::torus(32, 16);
  shells.emplace_back(torus, offset_top(torus.V, torus.F, 0.6));
  const SimpleMesh sphere = test::icosphere(3);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> shake(-0.08, 0.08);
  Eigen::MatrixXd shaken = offset_top(sphere.V, sphere.F, 0.05);
  for (Eigen::Index i = 0; i < shaken.size(); ++i) shaken(i) += shake(rng);
  shells.emplace_back(sphere, shaken);
  for (const auto& [mesh, top] : shells) {
    const int m = static_cast<int>(mesh.F.rows());
    const ShellCertificate c = certify_shell(mesh.V, top, mesh.F);
    Pairs non_adjacent;
    for (const auto& [a, b] : pairs_of(c, IntersectionKind::TopTop)) {
      const int f = a - m, g = b - m;
      bool share = false;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) share |= mesh.F(f, i) == mesh.F(g, j);
      if (!share) non_adjacent.emplace_back(f, g);
    }
    const Pairs old_self = self_intersecting_pairs(top, mesh.F);
    ASSERT_GT(old_self.size(), 0u);
    EXPECT_EQ(non_adjacent, old_self);
    EXPECT_GE(c.top_self_intersections, static_cast<int>(old_self.size()));
    Pairs top_base;
    for (const auto& [a, b] : pairs_of(c, IntersectionKind::TopBase)) top_base.emplace_back(b - m, a);
    std::sort(top_base.begin(), top_base.end());
    EXPECT_EQ(top_base, intersecting_pairs_between(top, mesh.F, mesh.V, mesh.F));
  }
}

// ---- the adjacency-aware test against an exact-construction brute force ----------------------

using Exact = CGAL::Exact_predicates_exact_constructions_kernel;

// Whether faces f and g meet outside the vertices and edges they share, by computing their
// intersection exactly and checking where it lies. Non-degenerate faces only.
bool brute_force_meets_beyond_shared(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, int f, int g) {
  auto point = [&](int v) { return Exact::Point_3(V(v, 0), V(v, 1), V(v, 2)); };
  const Exact::Triangle_3 a(point(F(f, 0)), point(F(f, 1)), point(F(f, 2)));
  const Exact::Triangle_3 b(point(F(g, 0)), point(F(g, 1)), point(F(g, 2)));
  const auto meet = CGAL::intersection(a, b);
  if (!meet) return false;
  std::vector<Exact::Point_3> shared;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (F(f, i) == F(g, j)) shared.push_back(point(F(f, i)));
  auto allowed = [&](const Exact::Point_3& x) {
    if (shared.size() == 1) return x == shared[0];
    if (shared.size() == 2) return Exact::Segment_3(shared[0], shared[1]).has_on(x);
    return false;
  };
  if (const auto* p = boost::get<Exact::Point_3>(&*meet)) return !allowed(*p);
  if (const auto* s = boost::get<Exact::Segment_3>(&*meet)) return !allowed(s->source()) || !allowed(s->target());
  return true; // a triangle or polygon: an area, more than shared vertices and edges
}

bool degenerate(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, int f) {
  auto point = [&](int v) { return Exact::Point_3(V(v, 0), V(v, 1), V(v, 2)); };
  return CGAL::collinear(point(F(f, 0)), point(F(f, 1)), point(F(f, 2)));
}

TEST(ShellCertificate, AdjacencyAwareTestMatchesExactConstructionsOnLatticeSurfaces) {
  // Grid surfaces whose vertices snap to a coarse lattice: folds, coplanar neighbours, touching
  // corners and collinear faces everywhere, and smooth stretches whose stars are embedded.
  std::mt19937 rng(11);
  int compared = 0, meeting = 0;
  for (int trial = 0; trial < 12; ++trial) {
    SimpleMesh m = test::plane(6);
    std::uniform_int_distribution<int> step(-1, 1), height(0, trial % 3 + 1);
    const double h = 2.0 / 6;
    for (Eigen::Index v = 0; v < m.V.rows(); ++v) {
      m.V(v, 0) += 0.5 * h * step(rng) * (trial % 2);
      m.V(v, 1) += 0.5 * h * step(rng);
      m.V(v, 2) = 0.5 * h * height(rng);
    }
    if (trial >= 6) m = test::permuted(m, trial);
    const Pairs found = surface_self_intersections(m.V, m.F);
    const std::set<std::pair<int, int>> found_set(found.begin(), found.end());
    for (int f = 0; f < m.F.rows(); ++f)
      for (int g = f + 1; g < m.F.rows(); ++g) {
        if (degenerate(m.V, m.F, f) || degenerate(m.V, m.F, g)) continue;
        const bool expected = brute_force_meets_beyond_shared(m.V, m.F, f, g);
        EXPECT_EQ(found_set.count({f, g}) == 1, expected) << "trial " << trial << " faces " << f << ", " << g;
        ++compared;
        meeting += expected;
      }
  }
  EXPECT_GT(meeting, 100); // the lattice makes plenty of real cases
  EXPECT_GT(compared, 10000);
}

TEST(ShellCertificate, PairSearchByFloatBoxesMissesNoTouchingOrNearlyTouchingPair) {
  // The pair search takes every pair whose float box covers meet and leaves the rest to the exact
  // test: a soup over shared lattice points, whose faces' boxes touch exactly (equal coordinates),
  // or miss by one ulp (a point nudged off the lattice, below float resolution: the float covers
  // still meet), and faces one ulp off collinear (triangles, not segments, for the exact test).
  // Scaled by powers of two (exact, ulps stay ulps) to negative coordinates, to floats' denormal
  // range and beyond the float range, where the covers are denormals, the largest float or
  // infinities.
  for (const double scale : {1.0, -1.0, 0x1p-125, 0x1p150}) {
    SCOPED_TRACE(scale);
    std::mt19937 rng(5);
    std::uniform_int_distribution<int> cell(0, 4), coin(0, 3);
    const int lattice_points = 70, nearly_flat = 10;
    Eigen::MatrixXd V(lattice_points + 3 * nearly_flat, 3);
    for (int v = 0; v < lattice_points; ++v)
      for (int d = 0; d < 3; ++d) {
        V(v, d) = 0.25 * cell(rng);
        if (coin(rng) == 0) V(v, d) = std::nextafter(V(v, d), coin(rng) < 2 ? -1.0 : 2.0);
      }
    for (int k = 0; k < nearly_flat; ++k) { // p, q and their midpoint one ulp off the line pq
      const int p = lattice_points + 3 * k;
      for (int d = 0; d < 3; ++d) {
        V(p, d) = 0.25 * cell(rng);
        V(p + 1, d) = V(p, d) + 0.5;
        V(p + 2, d) = V(p, d) + 0.25;
      }
      V(p + 2, k % 3) = std::nextafter(V(p + 2, k % 3), 2.0);
    }
    std::vector<Eigen::RowVector3i> faces;
    std::uniform_int_distribution<int> id(0, lattice_points - 1);
    while (faces.size() < 100) {
      const Eigen::RowVector3i f(id(rng), id(rng), id(rng));
      if (f[0] != f[1] && f[1] != f[2] && f[0] != f[2]) faces.push_back(f);
    }
    for (int k = 0; k < nearly_flat; ++k) {
      const int p = lattice_points + 3 * k;
      faces.emplace_back(p, p + 1, p + 2);
    }
    Eigen::MatrixXi F(static_cast<int>(faces.size()), 3);
    for (int f = 0; f < F.rows(); ++f) F.row(f) = faces[f];
    V *= scale;

    const Pairs found = surface_self_intersections(V, F);
    const std::set<std::pair<int, int>> found_set(found.begin(), found.end());
    int compared = 0, meeting = 0, flat_meeting = 0;
    for (int f = 0; f < F.rows(); ++f)
      for (int g = f + 1; g < F.rows(); ++g) {
        if (degenerate(V, F, f) || degenerate(V, F, g)) continue;
        const bool expected = brute_force_meets_beyond_shared(V, F, f, g);
        EXPECT_EQ(found_set.count({f, g}) == 1, expected) << "faces " << f << ", " << g;
        ++compared;
        meeting += expected;
        flat_meeting += expected && g >= F.rows() - nearly_flat;
      }
    for (int f = F.rows() - nearly_flat; f < F.rows(); ++f) EXPECT_FALSE(degenerate(V, F, f));
    EXPECT_GT(compared, 5000);
    EXPECT_GT(meeting, 1000);
    EXPECT_GT(flat_meeting, 20); // the nearly flat faces meet others as the triangles they are
  }
}

TEST(ShellCertificate, ShellPairsMatchExactConstructionsOnLatticeShells) {
  // Open and closed shells with lattice-snapped tops: every boundary pair (top, base, walls) the
  // certificate reports, and none other, meets beyond what it shares.
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> step(-1, 1);
  int meeting = 0;
  std::set<IntersectionKind> kinds;
  for (int trial = 0; trial < 6; ++trial) {
    const SimpleMesh m = trial % 2 ? test::plane(4) : test::icosphere(1);
    const int n = static_cast<int>(m.V.rows());
    const double q = trial % 2 ? 0.25 : 0.125; // lattice step
    Eigen::MatrixXd top = trial % 2 ? m.V : (1.25 * m.V).eval();
    if (trial % 2) top.col(2).array() += q;
    for (Eigen::Index i = 0; i < top.size(); ++i) top(i) += q * step(rng) * (trial >= 2);
    const ShellCertificate c = certify_shell(m.V, top, m.F);
    std::set<std::pair<int, int>> found;
    for (const BoundaryIntersection& p : c.intersections) {
      found.insert({p.a, p.b});
      kinds.insert(p.kind);
    }
    Eigen::MatrixXd X(2 * n, 3);
    X << m.V, top;
    const ShellBoundary b = shell_boundary(m.F, n);
    for (int f = 0; f < b.size(); ++f)
      for (int g = f + 1; g < b.size(); ++g) {
        if (degenerate(X, b.F, f) || degenerate(X, b.F, g)) continue;
        const bool expected = brute_force_meets_beyond_shared(X, b.F, f, g);
        EXPECT_EQ(found.count({f, g}) == 1, expected) << "trial " << trial << " rows " << f << ", " << g;
        meeting += expected;
      }
  }
  EXPECT_GT(meeting, 50);
  EXPECT_EQ(kinds.size(), 3u); // top/top, top/base and wall pairs all occur (the bases are clean)
}

TEST(ShellCertificate, TopCornersTouchingATiltedBaseFarFromTheOriginAreJudgedExactly) {
  // The pair tests reject most pairs of a thin shell by a slab along one face's normal computed in
  // doubles (exact_faces.h, slabs_separate); its margin must cover the rounding, which grows with
  // the coordinates. Here a tilted base with generic (rounded) coordinates lies 2^20 from the
  // origin, and every other top corner is put on a base face up to rounding, then a few ulps up
  // or down: every pair of boundary triangles must be judged as the exact
  // construction judges it (without the margin some of them are called apart while they touch).
  const SimpleMesh m = test::plane(3);
  const int n = static_cast<int>(m.V.rows());
  const double far = 1048576;
  std::mt19937 rng(29);
  std::uniform_real_distribution<double> wobble(-0.01, 0.01);
  Eigen::MatrixXd base(n, 3), top(n, 3);
  for (int v = 0; v < n; ++v) {
    const double x = m.V(v, 0) * 1.1, y = m.V(v, 1) * 0.9;
    base.row(v) << far + x, far / 3 + y, far / 7 + 0.3 * x + 0.7 * y + wobble(rng);
    top.row(v) = base.row(v) + Eigen::RowVector3d(-0.3, -0.7, 1) / 8;
  }
  Eigen::MatrixXd X(2 * n, 3);
  const ShellBoundary b = shell_boundary(m.F, n);
  std::uniform_int_distribution<int> face(0, static_cast<int>(m.F.rows()) - 1), ulps(-3, 3);
  int meeting = 0, apart = 0;
  for (int trial = 0; trial < 40; ++trial) {
    Eigen::MatrixXd moved = top;
    for (int v = trial % 2; v < n; v += 2) { // every other top corner, the rest stay clear above
      const int g = face(rng), k = ulps(rng);
      moved.row(v) = 0.25 * base.row(m.F(g, 0)) + 0.25 * base.row(m.F(g, 1)) + 0.5 * base.row(m.F(g, 2));
      for (int i = 0; i < std::abs(k); ++i)
        moved(v, 2) = std::nextafter(moved(v, 2), k > 0 ? INFINITY : -INFINITY);
    }
    const ShellCertificate c = certify_shell(base, moved, m.F);
    std::set<std::pair<int, int>> found;
    for (const BoundaryIntersection& p : c.intersections) found.insert({p.a, p.b});
    X << base, moved;
    for (int f = 0; f < b.size(); ++f)
      for (int h = f + 1; h < b.size(); ++h) {
        if (degenerate(X, b.F, f) || degenerate(X, b.F, h)) continue;
        const bool expected = brute_force_meets_beyond_shared(X, b.F, f, h);
        EXPECT_EQ(found.count({f, h}) == 1, expected) << "trial " << trial << " rows " << f << ", " << h;
        const bool top_base = b.part[f] != b.part[h] && b.part[f] != BoundaryPart::Wall && b.part[h] != BoundaryPart::Wall;
        meeting += expected && top_base;
        apart += !expected && top_base;
      }
  }
  EXPECT_GT(meeting, 100);
  EXPECT_GT(apart, 1000);
}

TEST(ShellCertificate, NearlyFlatStarTrianglesAreJudgedExactly) {
  // Flat fans of six triangles around a vertex, one far corner placed on the line through the
  // centre and the previous far corner up to rounding: that triangle is a hair's breadth from
  // degenerate, folded back over its neighbour or not. The star shortcut must only accept fans
  // whose projected triangles are all exactly positive.
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> jitter(-0.3, 0.3), stretch(0.3, 3);
  int folded = 0;
  for (int trial = 0; trial < 400; ++trial) {
    Eigen::MatrixXd V(7, 3);
    V.row(0) << jitter(rng), jitter(rng), 0;
    for (int i = 0; i < 6; ++i) {
      const double angle = M_PI / 3 * (i + jitter(rng));
      V.row(1 + i) << std::cos(angle), std::sin(angle), 0;
    }
    const int k = 2 + trial % 5; // far corner k lands on the ray from the centre through k - 1
    V.row(k) = V.row(0) + stretch(rng) * (V.row(k - 1) - V.row(0));
    Eigen::MatrixXi F(6, 3);
    for (int i = 0; i < 6; ++i) F.row(i) << 0, 1 + i, 1 + (i + 1) % 6;
    const Pairs found = surface_self_intersections(V, F);
    const std::set<std::pair<int, int>> found_set(found.begin(), found.end());
    for (int f = 0; f < 6; ++f)
      for (int g = f + 1; g < 6; ++g) {
        if (degenerate(V, F, f) || degenerate(V, F, g)) continue;
        const bool expected = brute_force_meets_beyond_shared(V, F, f, g);
        EXPECT_EQ(found_set.count({f, g}) == 1, expected) << "trial " << trial << " faces " << f << ", " << g;
        folded += expected;
      }
  }
  EXPECT_GT(folded, 50);
}

TEST(ShellCertificate, AStarWindingTwiceAroundItsVertexIsFound) {
  // Six faces around vertex 0 whose far corners circle it twice (120 degrees per face), rising
  // like a screw: every face turns the same way seen from above, yet a closed fan that winds
  // twice cannot be embedded, so some pair must meet beyond what it shares.
  Eigen::MatrixXd V(7, 3);
  V.row(0) << 0, 0, 0;
  for (int i = 0; i < 6; ++i) {
    const double angle = 2 * M_PI * i / 3, radius = i < 3 ? 1.0 : 1.5;
    V.row(1 + i) << radius * std::cos(angle), radius * std::sin(angle), 0.1 * i;
  }
  Eigen::MatrixXi F(6, 3);
  for (int i = 0; i < 6; ++i) F.row(i) << 0, 1 + i, 1 + (i + 1) % 6;
  const Pairs found = surface_self_intersections(V, F);
  EXPECT_FALSE(found.empty());
  for (const auto& [f, g] : found) EXPECT_TRUE(brute_force_meets_beyond_shared(V, F, f, g)) << f << "," << g;
}

TEST(ShellCertificate, DegenerateFacesAreTestedAsTheSegmentsTheyCover) {
  // Triangle 0-1-2 in z = 0; flat faces (collinear corners) around it.
  Eigen::MatrixXd V(13, 3);
  V << 0, 0, 0, 2, 0, 0, 0, 2, 0, //
      3, 0, 0,                      // 3: on the line 0-1, beyond 1
      4, 0, 0,                      // 4: further along it
      0.5, 0.5, 0,                  // 5: inside the triangle
      -1, -1, 0,                    // 6: on the line 0-5, behind 0
      -2, -2, 0,                    // 7: further behind
      -1, 1, 0,                     // 8, 9: a line through 0 that misses the triangle's inside
      1, -1, 0,                     //
      0, 0, 0,                      // 10, 11: distinct vertices on top of vertex 0
      0, 0, 0,                      //
      -1, 0, 0;                     // 12: on the line 0-1, behind 0
  auto count = [&](std::initializer_list<std::array<int, 3>> faces) {
    Eigen::MatrixXi F(faces.size(), 3);
    int r = 0;
    for (const auto& f : faces) F.row(r++) << f[0], f[1], f[2];
    return surface_self_intersections(V, F).size();
  };
  EXPECT_EQ(count({{0, 1, 2}, {1, 0, 3}}), 0u); // flat neighbour on the shared edge's line
  EXPECT_EQ(count({{0, 1, 3}, {1, 0, 4}}), 1u); // two flat ones, both reaching beyond 1
  EXPECT_EQ(count({{0, 1, 2}, {0, 6, 5}}), 1u); // flat, through vertex 0 into the triangle
  EXPECT_EQ(count({{0, 1, 2}, {0, 6, 7}}), 0u); // flat, from vertex 0 away from the triangle
  EXPECT_EQ(count({{0, 1, 2}, {3, 4, 5}}), 1u); // flat, no common id, its segment ends inside
  EXPECT_EQ(count({{0, 1, 2}, {8, 0, 9}}), 0u); // flat across vertex 0, touching the triangle there only
  EXPECT_EQ(count({{0, 10, 3}, {0, 11, 12}}), 0u); // segments leaving vertex 0 in opposite directions
  EXPECT_EQ(count({{0, 10, 3}, {0, 11, 4}}), 1u); // ... in the same direction
}

TEST(ShellCertificate, APartInsideAnotherPartsLayerIsNested) {
  // Two spheres facing out, radius 1 inside 1.04. With tops 0.1 out, the inner top (radius 1.1)
  // lies in the outer layer and the outer base (1.04) in the inner one, and no two boundary
  // triangles meet: the pair tests see nothing, condition 4 the two sheets.
  const TriMesh m = test::nested_spheres(2, 1.04);
  const int n = static_cast<int>(m.V.rows()), half = n / 2;
  const ShellCertificate c = certify_shell(m.V, 1.1 * m.V, m.F);
  EXPECT_EQ(c.inverted_tets, 0);
  EXPECT_TRUE(c.intersections.empty());
  EXPECT_EQ(c.nested_parts, 2);
  EXPECT_FALSE(c.valid());
  ASSERT_EQ(c.nested.size(), 2u);
  // The outer part's base probe (its lowest vertex, half) in an inner tet, the inner part's top
  // probe (top n + 0) in an outer one.
  EXPECT_EQ(c.nested[0].first, half);
  EXPECT_LT(c.nested[0].second / 3, m.F.rows() / 2);
  EXPECT_EQ(c.nested[1].first, n);
  EXPECT_GE(c.nested[1].second / 3, m.F.rows() / 2);
  // The terminal summary names them (one sheet in the singular).
  EXPECT_NE(certificate_summary(c).find("valid        NO (exact: 0 inverted tets; top/top 0, top/base 0, wall 0 "
                                        "intersecting face pairs; 2 sheets inside another part's layer)"),
            std::string::npos)
      << certificate_summary(c);
  EXPECT_EQ(nested_parts_phrase(1), "1 sheet inside another part's layer");
  // Thin enough that the inner top stays below the outer base: clean.
  expect_clean(certify_shell(m.V, 1.03 * m.V, m.F));
  // A small sphere wholly inside the outer sphere's layer: both its sheets are nested.
  TriMesh small = make_sphere(1, 0.01);
  small.V.col(0).array() += 1.09;
  TriMesh both;
  both.V.resize(small.V.rows() + half, 3);
  both.V << small.V, m.V.bottomRows(half);
  both.F.resize(small.F.rows() + m.F.rows() / 2, 3);
  both.F << small.F, (m.F.bottomRows(m.F.rows() / 2).array() - half + static_cast<int>(small.V.rows())).matrix();
  const Eigen::MatrixXd centre = Eigen::RowVector3d(1.09, 0, 0).replicate(small.V.rows(), 1);
  Eigen::MatrixXd top(both.V.rows(), 3);
  top << centre + 1.5 * (small.V - centre), (1.14 / 1.04) * m.V.bottomRows(half); // outer layer: 1.04 to 1.14
  const ShellCertificate s = certify_shell(both.V, top, both.F);
  EXPECT_TRUE(s.intersections.empty());
  EXPECT_EQ(s.nested_parts, 2);
  // One part only: nothing to nest, and the certifier of many frames says the same.
  EXPECT_EQ(certify_shell(m.V.topRows(half), 1.1 * m.V.topRows(half), m.F.topRows(m.F.rows() / 2)).nested_parts, 0);
  ShellCertifier certifier(m.F, n);
  EXPECT_EQ(certifier.certify(m.V, 1.03 * m.V).nested_parts, 0);
  EXPECT_EQ(certifier.certify(m.V, 1.1 * m.V).nested, c.nested);
}

// ---- one certifier over the frames of a motion (its trees refit, not rebuilt) ------------------

void expect_same(const ShellCertificate& a, const ShellCertificate& b, const std::string& where) {
  EXPECT_EQ(a.inverted_tet_ids, b.inverted_tet_ids) << where;
  EXPECT_EQ(a.intersections, b.intersections) << where;
  EXPECT_EQ(a.inverted_tets, b.inverted_tets) << where;
  EXPECT_EQ(a.top_self_intersections, b.top_self_intersections) << where;
  EXPECT_EQ(a.top_base_intersections, b.top_base_intersections) << where;
  EXPECT_EQ(a.wall_intersections, b.wall_intersections) << where;
  EXPECT_EQ(a.base_self_intersections, b.base_self_intersections) << where;
}

TEST(ShellCertifier, FramesOfAFoldEqualFreshCertificatesAndExactConstructions) {
  // A thick plane shell folded shut and on through itself (real top/top, top/base, wall and
  // base/base crossings), its top carried rigidly with the base and shaken in some frames
  // (inverted tets). One certifier follows the frames, refitting the trees it built at rest; every
  // frame must get exactly the fresh certify_shell's answer, and every reported pair (and no
  // other) must meet by exact constructions.
  const SimpleMesh m = test::plane(6);
  const int n = static_cast<int>(m.V.rows());
  const Eigen::MatrixXd rest_top = offset_top(m.V, m.F, 0.2);
  Eigen::MatrixXd rest(2 * n, 3);
  rest << m.V, rest_top;
  const MotionFrame frame = motion_frame(m.V);
  const ShellBoundary boundary = shell_boundary(m.F, n);
  ShellCertifier certifier(m.F, n);
  CertifyOptions without_base;
  without_base.base_self_intersections = false;
  CertifyOptions tets_only;
  tets_only.test_intersections = false;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> shake(-0.15, 0.15);
  std::set<IntersectionKind> kinds;
  int clean_frames = 0, inverted = 0;
  struct Last {
    ShellCertificate all, without_base;
    Eigen::MatrixXd base, top;
  };
  std::optional<Last> last;
  for (double degrees : {0.0, 60.0, 120.0, 170.0, 185.0, 200.0, 230.0, 260.0, -200.0, 90.0}) {
    const Eigen::MatrixXd X = bend(rest, frame, degrees, 0.5);
    const Eigen::MatrixXd base = X.topRows(n);
    Eigen::MatrixXd top = X.bottomRows(n);
    if (degrees == 90.0)
      for (Eigen::Index i = 0; i < top.size(); ++i) top(i) += shake(rng);
    const std::string where = "bend " + std::to_string(degrees);
    const ShellCertificate c = certifier.certify(base, top);
    const ShellCertificate fresh_without_base = certify_shell(base, top, m.F, without_base);
    expect_same(c, certify_shell(base, top, m.F), where);
    expect_same(certifier.certify(base, top, without_base), fresh_without_base, where);
    expect_same(certifier.certify(base, top, tets_only), certify_shell(base, top, m.F, tets_only), where);
    // From the last frame's certificate (base and top moved, every row changed): the same answer.
    if (last) {
      expect_same(recertify_shell(last->all, last->base, last->top, base, top, m.F), c, where + " (recertified)");
      expect_same(recertify_shell(last->without_base, last->base, last->top, base, top, m.F, without_base),
                  fresh_without_base, where + " (recertified, without base/base)");
    }
    last = Last{c, fresh_without_base, base, top};
    clean_frames += c.valid();
    inverted += c.inverted_tets;

    std::set<std::pair<int, int>> found;
    for (const BoundaryIntersection& p : c.intersections) {
      found.insert({p.a, p.b});
      kinds.insert(p.kind);
    }
    Eigen::MatrixXd Y(2 * n, 3);
    Y << base, top;
    auto box = [&](int row) {
      Eigen::AlignedBox3d b;
      for (int k = 0; k < 3; ++k) b.extend(Y.row(boundary.F(row, k)).transpose().eval());
      return b;
    };
    for (int f = 0; f < boundary.size(); ++f)
      for (int g = f + 1; g < boundary.size(); ++g) {
        const bool expected = box(f).intersects(box(g)) && brute_force_meets_beyond_shared(Y, boundary.F, f, g);
        EXPECT_EQ(found.count({f, g}) == 1, expected) << where << " rows " << f << ", " << g;
      }
  }
  EXPECT_GE(clean_frames, 3); // rest, 60 and 120 degrees at least
  EXPECT_GT(inverted, 0);     // the shaken frame
  EXPECT_EQ(kinds.size(), 4u); // top/top, top/base, wall and base/base crossings all occur
}

TEST(RecertifyShell, LocalEditsOfATopGetTheFreshCertificate) {
  // A sphere shell whose top is edited a vertex or a few at a time: pushed through the base
  // (inverted tets, top/base pairs), across its neighbours (top/top pairs) and back. Each state
  // is recertified from the one before; the answer must be the fresh certificate's, pairs among
  // the unmoved tops (kept, not tested again) included.
  const SimpleMesh m = test::icosphere(3);
  const int n = static_cast<int>(m.V.rows());
  const double eta = 0.1;
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> vertex(0, n - 1);
  std::uniform_real_distribution<double> unit(-1, 1);
  Eigen::MatrixXd top = (1 + eta) * m.V;
  CertifyOptions without_base;
  without_base.base_self_intersections = false;
  ShellCertificate previous = certify_shell(m.V, top, m.F);
  int invalid_states = 0, kept_pairs = 0, back_to_valid = 0;
  for (int step = 0; step < 40; ++step) {
    Eigen::MatrixXd next = top;
    if (step % 10 == 9) {
      next = (1 + eta) * m.V; // every edit undone at once
    } else {
      for (int k = 0, edits = 1 + step % 3; k < edits; ++k) {
        const int i = vertex(rng);
        const Eigen::RowVector3d normal = m.V.row(i).normalized();
        // Down through the base, or sideways over the neighbours, by up to two thicknesses.
        next.row(i) += (step % 2 == 0 ? -2.5 * eta * normal
                                      : 2 * eta * Eigen::RowVector3d(unit(rng), unit(rng), unit(rng)));
      }
    }
    const std::string where = "step " + std::to_string(step);
    const ShellCertificate fresh = certify_shell(m.V, next, m.F);
    const ShellCertificate again = recertify_shell(previous, m.V, top, m.V, next, m.F);
    expect_same(again, fresh, where);
    EXPECT_EQ(again.nested, fresh.nested) << where;
    expect_same(recertify_shell(certify_shell(m.V, top, m.F, without_base), m.V, top, m.V, next, m.F, without_base),
                certify_shell(m.V, next, m.F, without_base), where + " (without base/base)");
    // Pairs of the previous state that the edit left alone.
    for (const BoundaryIntersection& p : previous.intersections)
      kept_pairs += std::find(fresh.intersections.begin(), fresh.intersections.end(), p) != fresh.intersections.end();
    invalid_states += !fresh.valid();
    back_to_valid += fresh.valid() && !previous.valid();
    previous = again;
    top = next;
  }
  EXPECT_GT(invalid_states, 20);
  EXPECT_GT(kept_pairs, 20);
  EXPECT_GE(back_to_valid, 3); // the undo steps
  // Nothing moved: the previous answer; sheets nested after every vertex moved are found again.
  expect_same(recertify_shell(previous, m.V, top, m.V, top, m.F), previous, "unmoved");
  const TriMesh two = test::nested_spheres(2, 1.04);
  const ShellCertificate thin = certify_shell(two.V, 1.03 * two.V, two.F);
  const ShellCertificate thick = certify_shell(two.V, 1.1 * two.V, two.F);
  ASSERT_EQ(thick.nested_parts, 2);
  EXPECT_EQ(recertify_shell(thin, two.V, 1.03 * two.V, two.V, 1.1 * two.V, two.F).nested, thick.nested);
  EXPECT_EQ(recertify_shell(thick, two.V, 1.1 * two.V, two.V, 1.03 * two.V, two.F).nested_parts, 0);
}

TEST(RecertifyShell, RefusesPreviousShellsAndCertificatesThatDoNotMatch) {
  const SimpleMesh m = test::icosphere(1);
  const Eigen::MatrixXd top = 1.1 * m.V;
  const ShellCertificate c = certify_shell(m.V, top, m.F);
  EXPECT_THROW(recertify_shell(c, m.V, top.topRows(5), m.V, top, m.F), InputError);
  EXPECT_THROW(recertify_shell(c, m.V.topRows(5), top, m.V, top, m.F), InputError);
  CertifyOptions tets_only, without_base;
  tets_only.test_intersections = false;
  without_base.base_self_intersections = false;
  const ShellCertificate tets = certify_shell(m.V, top, m.F, tets_only);
  EXPECT_THROW(recertify_shell(tets, m.V, top, m.V, top, m.F), InputError); // its pairs were not tested
  EXPECT_THROW(recertify_shell(c, m.V, top, m.V, top, m.F, without_base), InputError);
  EXPECT_THROW(recertify_shell(certify_shell(m.V, top, m.F, without_base), m.V, top, m.V, top, m.F), InputError);
  expect_same(recertify_shell(tets, m.V, top, m.V, 0.5 * top, m.F, tets_only),
              certify_shell(m.V, 0.5 * top, m.F, tets_only), "tets only");
  Eigen::MatrixXd nan = top;
  nan(3, 1) = std::nan("");
  EXPECT_THROW(recertify_shell(c, m.V, top, m.V, nan, m.F), InputError);
}

TEST(ShellCertificate, TestsCanBeSkippedAndBadInputIsRefused) {
  const SimpleMesh m = test::icosphere(1);
  CertifyOptions tets_only;
  tets_only.test_intersections = false;
  const ShellCertificate c = certify_shell(m.V, 1.1 * m.V, m.F, tets_only);
  EXPECT_FALSE(c.intersections_tested());
  EXPECT_EQ(c.top_self_intersections, -1);
  EXPECT_EQ(c.base_self_intersections, -1);
  EXPECT_FALSE(c.valid()); // not shown valid without the pair tests
  EXPECT_EQ(c.inverted_tets, 0);

  EXPECT_THROW(certify_shell(m.V, m.V.topRows(5), m.F), InputError);
  Eigen::MatrixXi bad = m.F;
  bad(2, 1) = static_cast<int>(m.V.rows());
  EXPECT_THROW(certify_shell(m.V, m.V, bad), InputError);
  bad(2, 1) = bad(2, 0);
  EXPECT_THROW(certify_shell(m.V, m.V, bad), InputError);
  Eigen::MatrixXd nan = m.V;
  nan(3, 1) = std::nan("");
  EXPECT_THROW(certify_shell(m.V, nan, m.F), InputError);
}

// ---- the certificate in the metrics and their report -------------------------------------------

TEST(ShellMetricsCertificate, ReportSaysValidInvalidOrUnknown) {
  const int res = 4;
  const SimpleMesh m = test::plane(res);
  const double eta = 0.25;
  Eigen::MatrixXd top = lifted(m.V, eta);
  const int n = static_cast<int>(m.V.rows()), faces = static_cast<int>(m.F.rows());

  const ShellMetrics clean = shell_metrics(m.V, m.F, top, eta);
  nlohmann::json j = metrics_report(clean, n, faces, eta);
  EXPECT_EQ(j["valid"], true);
  EXPECT_EQ(j["certificate"]["exact"], true);
  EXPECT_EQ(j["certificate"]["wall_intersections"], 0);
  EXPECT_EQ(j["base_self_intersections"], 0);
  EXPECT_FALSE(j.contains("inverted_tets"));
  EXPECT_NE(metrics_summary(clean, n, faces, eta).find("valid        yes"), std::string::npos);

  // Without intersection counts the pair tests are skipped: validity unknown, counts null...
  const ShellMetrics untested = shell_metrics(m.V, m.F, top, eta, false);
  j = metrics_report(untested, n, faces, eta);
  EXPECT_TRUE(j["valid"].is_null());
  EXPECT_TRUE(j["certificate"]["top_self_intersections"].is_null());
  EXPECT_TRUE(j["certificate"]["wall_intersections"].is_null());
  EXPECT_TRUE(j["base_self_intersections"].is_null());
  EXPECT_EQ(j["certificate"]["inverted_tets"], 0);
  EXPECT_NE(metrics_summary(untested, n, faces, eta).find("valid        unknown"), std::string::npos);

  // ... but an inverted tet settles it.
  const int v = grid_vertex(res, 2, 2);
  top(v, 2) = -0.1;
  const ShellMetrics inverted = shell_metrics(m.V, m.F, top, eta, false);
  j = metrics_report(inverted, n, faces, eta);
  EXPECT_EQ(j["valid"], false);
  EXPECT_EQ(j["certificate"]["inverted_tets"], static_cast<int>(tets_through_vertical_edge(m.F, n, v).size()));
  EXPECT_NE(metrics_summary(inverted, n, faces, eta).find("valid        NO"), std::string::npos);
}

TEST(ShellMetricsCertificate, ThinnedVerticesAreThoseBelowNineTenthsOfEta) {
  // Flat plane shell: every top vertex is exactly eta above the base, except the lowered ones.
  const int res = 4;
  const SimpleMesh m = test::plane(res);
  const double eta = 0.25;
  Eigen::MatrixXd top = lifted(m.V, eta);
  EXPECT_EQ(shell_metrics(m.V, m.F, top, eta, false).thinned_vertices, 0);
  top(grid_vertex(res, 2, 2), 2) = 0.5 * eta;
  top(grid_vertex(res, 1, 3), 2) = 0.89 * eta;
  top(grid_vertex(res, 3, 1), 2) = 0.91 * eta; // thinner than eta, not below 0.9 eta
  const ShellMetrics metrics = shell_metrics(m.V, m.F, top, eta, false);
  EXPECT_EQ(metrics.thinned_vertices, 2);
  EXPECT_EQ(metrics_report(metrics, static_cast<int>(m.V.rows()), static_cast<int>(m.F.rows()), eta)["thinned_vertices"], 2);
}

TEST(ShellMetricsCertificate, StretchFromTetsMadeInBlocksIsThatOfTheWholeSet) {
  // Without rest tets the metrics make the normal prisms' tets a block of faces at a time; with
  // several blocks (81,920 faces) every per-tet figure and every statistic must be those measured
  // against the whole set at once, bit for bit, on a top that stretches and inverts some tets.
  const SimpleMesh m = test::icosphere(6);
  const int n = static_cast<int>(m.V.rows());
  const double eta = 0.01;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> jitter(-0.8 * eta, 0.8 * eta);
  Eigen::MatrixXd top = offset_top(m.V, m.F, eta);
  for (int i = 0; i < n; ++i)
    for (int d = 0; d < 3; ++d) top(i, d) += jitter(rng);
  const RestTets whole = normal_prism_rest_tets(m.V, m.F, eta);
  const ShellMetrics expected = shell_metrics(m.V, m.F, top, eta, false, whole);
  const ShellMetrics blocks = shell_metrics(m.V, m.F, top, eta, false);
  ASSERT_GT(expected.stretch.inverted, 0);
  EXPECT_TRUE(blocks.tet_stretch == expected.tet_stretch);
  EXPECT_TRUE(blocks.tet_determinant == expected.tet_determinant);
  EXPECT_EQ(blocks.stretch.volume_mean, expected.stretch.volume_mean);
  EXPECT_EQ(blocks.stretch.mean, expected.stretch.mean);
  EXPECT_EQ(blocks.stretch.p99, expected.stretch.p99);
  EXPECT_EQ(blocks.stretch.inverted, expected.stretch.inverted);
}

} // namespace
} // namespace gshell
