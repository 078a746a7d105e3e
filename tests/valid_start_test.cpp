// The guarded generation's valid start (guard/valid_start.h): from a wanted top that inverts tets
// and intersects itself, the start is valid by an exact certificate; the bisection passes only
// raise vertices the halving pulled in (never lower one, never touch one it left alone) and stay
// valid, so the refined start is at least as thick everywhere and thicker where the halving
// overshot.
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/guard/extrusion_directions.h>
#include <gshell/guard/valid_start.h>
#include <gshell/quality/shell_certificate.h>
#include <gshell/shell/offset_shell.h>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

using namespace gshell;

namespace {

// valid(): no inverted tet and no intersecting pair of any kind, by exact predicates.
void expect_certified_valid(const TriMesh& m, const ValidStart& s) {
  EXPECT_TRUE(certify_shell(m.V, s.top, m.F).valid());
  EXPECT_TRUE(s.inverted_tets.empty() && s.intersections.empty());
}

// The start from the offset surface at thickness eta, with the extrusion directions of (V, F).
ValidStart start_of_offset(const TriMesh& m, double eta, ValidStartOptions options = {}) {
  options.fallback_length = eta;
  return valid_start(m.V, m.F, offset_top(m.V, m.F, eta), extrusion_directions(m.V, m.F), {}, {}, options);
}

} // namespace

TEST(ValidStart, BisectionRaisesThePulledInVerticesAndStaysValid) {
  // A torus whose offset is thicker than its hole (R - r = 0.6 < eta): the offset top inverts
  // and crosses itself around the axis, the outside is fine.
  const TriMesh m = make_torus(24, 1.0, 0.4);
  const double eta = 0.9;
  const Eigen::MatrixXd P = offset_top(m.V, m.F, eta);
  ASSERT_FALSE(certify_shell(m.V, P, m.F).valid()) << "the case no longer fails";
  const ExtrusionDirections d = extrusion_directions(m.V, m.F);
  ValidStartOptions halving;
  halving.fallback_length = eta;
  ValidStartOptions refined = halving;
  refined.refine_passes = 6;
  const ValidStart a = valid_start(m.V, m.F, P, d, {}, {}, halving);
  const ValidStart b = valid_start(m.V, m.F, P, d, {}, {}, refined);
  expect_certified_valid(m, a);
  expect_certified_valid(m, b);
  EXPECT_GT(b.rounds, a.rounds);
  int raised = 0;
  for (int i = 0; i < m.V.rows(); ++i) {
    EXPECT_GE(b.scale[i], a.scale[i]) << i;
    EXPECT_LE(b.scale[i], 1.0) << i;
    if (a.scale[i] == 1) EXPECT_TRUE(b.top.row(i) == P.row(i)) << i; // untouched where nothing was wrong
    raised += b.scale[i] > a.scale[i];
  }
  EXPECT_GT(raised, 0);
  EXPECT_GT(b.scale.sum(), a.scale.sum());
}

TEST(ValidStart, BackoffLowersOnlyPulledInVerticesAndStaysValid) {
  const TriMesh m = make_torus(24, 1.0, 0.4);
  const double eta = 0.9;
  const Eigen::MatrixXd P = offset_top(m.V, m.F, eta);
  const ExtrusionDirections d = extrusion_directions(m.V, m.F);
  ValidStartOptions refined;
  refined.fallback_length = eta;
  refined.refine_passes = 6;
  ValidStartOptions backed = refined;
  backed.backoff = 0.8;
  const ValidStart a = valid_start(m.V, m.F, P, d, {}, {}, refined);
  const ValidStart b = valid_start(m.V, m.F, P, d, {}, {}, backed);
  expect_certified_valid(m, b);
  for (int i = 0; i < m.V.rows(); ++i) {
    if (a.scale[i] == 1) EXPECT_EQ(b.scale[i], 1.0) << i;
    else EXPECT_LE(b.scale[i], a.scale[i]) << i;
  }
}

// The start gives up on a violation once its vertices have been thinned max_rounds - 1 times, not
// after max_rounds rounds in all: where the layer is much thicker than the base's features, it
// thins as a front spreading a ring or so per round, each vertex thinned a few times only, and
// ending it after max_rounds rounds left a start that was not valid through no fault of the base.
TEST(ValidStart, AThinningFrontLongerThanMaxRoundsStillEndsValid) {
  // A corrugated sheet of thin triangles (5:1) under a layer far thicker than its ridges are
  // deep: thinning a vertex shears the thin prisms towards its unthinned neighbours into new
  // inverted tets, so the thinning spreads ring by ring.
  TriMesh m = make_plane(32);
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    m.V(i, 2) = 0.02 * std::sin(12 * m.V(i, 0)) * std::cos(9 * m.V(i, 1));
    m.V(i, 1) *= 0.2;
  }
  const double eta = 2;
  ValidStartOptions options;
  const ValidStart all = start_of_offset(m, eta, options);
  expect_certified_valid(m, all);
  const int thinnings = static_cast<int>(std::lround(-std::log2(all.scale.minCoeff()))); // the most of one vertex
  ASSERT_GT(all.rounds, thinnings + 2) << "the case no longer thins as a front";
  // Rounds enough for every vertex's thinnings, fewer than the front needs in all: the same start.
  options.max_rounds = thinnings + 2;
  const ValidStart front = start_of_offset(m, eta, options);
  expect_certified_valid(m, front);
  EXPECT_EQ(front.rounds, all.rounds);
  EXPECT_TRUE(front.scale == all.scale);
  // No thinning allowed: given up at the first check, with what it found reported.
  options.max_rounds = 1;
  const ValidStart none = start_of_offset(m, eta, options);
  EXPECT_EQ(none.rounds, 1);
  EXPECT_FALSE(none.inverted_tets.empty());
}

// Two flat slabs (2 x 2 x 0.01) lying on each other 1e-7 apart, shifted, under a layer of 0.15:
// every top of the lower slab's upper face and of the upper slab's lower face must come down to
// the gap, about 2^-21 of the layer, while a front spreads over the slabs' edges and sides. A top
// behind the front stays in a crossing pair only through a triangle that reaches the front, and
// once it has been thinned max_rounds - 1 times it waits there while the front thins on: giving up
// then (as the start did until 2026-12-07) left 187 crossing pairs.
TEST(ValidStart, AVertexThinnedAsOftenAsItMayWaitsWhileTheFrontGoesOn) {
  TriMesh cube;
  cube.V.resize(8, 3);
  for (int i = 0; i < 8; ++i) cube.V.row(i) << (i & 1), (i >> 1) & 1, (i >> 2) & 1;
  cube.F.resize(12, 3);
  cube.F << 0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5;
  const TriMesh c = midpoint_subdivision(cube, 3);
  const Eigen::Index n = c.V.rows();
  TriMesh m;
  m.V.resize(2 * n, 3);
  m.F.resize(2 * c.F.rows(), 3);
  for (Eigen::Index i = 0; i < n; ++i) {
    m.V.row(i) << 2 * c.V(i, 0) - 1, 2 * c.V(i, 1) - 1, 0.01 * c.V(i, 2);
    m.V.row(n + i) << m.V(i, 0) + 0.3, m.V(i, 1) + 0.2, m.V(i, 2) + 0.01 + 1e-7;
  }
  m.F << c.F, c.F.array() + static_cast<int>(n);
  ASSERT_TRUE(certify_shell(m.V, m.V, m.F).base_self_intersections == 0) << "the slabs touch";
  const ValidStartOptions options;
  const ValidStart s = start_of_offset(m, 0.15, options);
  expect_certified_valid(m, s);
  // Every vertex thinned at most max_rounds - 1 times, and one as often as that, before the end.
  EXPECT_EQ(s.scale.minCoeff(), std::pow(options.thinning, options.max_rounds - 1));
  EXPECT_GT(s.rounds, options.max_rounds);
  EXPECT_LE(s.rounds, 10 * options.max_rounds);
}

// On the rim of an open surface the straight path back to the base can be blocked: near the
// vertex the side wall over a boundary edge is the sector between the edge and the path's
// direction, and where that sector cuts another of the vertex's faces the two meet however thin
// the layer. There the path ends along the extrusion direction instead (CGAL's
// double-torus-3-holes at curvature 0.3 kept a wall through vertex 52's own face).
TEST(ValidStart, ARimVertexWhoseStraightPathIsBlockedLeavesAlongItsDirection) {
  // An open fan of three faces around vertex 0; its wanted top lies along u, which sees every
  // face (margin 0.27) but whose wall over a boundary edge cuts the fan.
  TriMesh m;
  m.V.resize(5, 3);
  m.V << 0, 0, 0, //
      0.998, 0.059, 0.087, //
      -0.415, 0.91, 0.93, //
      -0.315, -0.949, -1.485, //
      -0.052, -0.999, 0.369;
  m.F.resize(3, 3);
  m.F << 0, 1, 2, //
      0, 2, 3, //
      0, 3, 4;
  const Eigen::RowVector3d u = Eigen::RowVector3d(-0.698, -0.648, -0.304).normalized();
  const double eta = 0.3;
  Eigen::MatrixXd P = offset_top(m.V, m.F, eta);
  P.row(0) = eta * u;
  const ExtrusionDirections d = extrusion_directions(m.V, m.F);
  Eigen::MatrixXd along_u = d.direction;
  along_u.row(0) = u;
  ASSERT_EQ(rim_vertices_with_blocked_walls(m.V, m.F, along_u, {0}), std::vector<int>{0}) << "the case no longer blocks";
  ASSERT_TRUE(rim_vertices_with_blocked_walls(m.V, m.F, d.direction, {0, 1, 2, 3, 4}).empty());
  for (int f = 0; f < 3; ++f) {
    const Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    ASSERT_GT((b - a).cross(c - a).normalized().dot(u.transpose()), 0.2) << "u no longer sees face " << f;
  }
  ValidStartOptions options;
  options.fallback_length = eta;
  const ValidStart s = valid_start(m.V, m.F, P, d, {}, {}, options);
  expect_certified_valid(m, s);
  EXPECT_LT(s.scale[0], 1);
  EXPECT_GT(s.scale[0], 1e-3) << "thinned far more than the fan needs";
}
