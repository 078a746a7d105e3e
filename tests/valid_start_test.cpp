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

#include <gtest/gtest.h>

#include <cmath>

using namespace gshell;

namespace {

// valid(): no inverted tet and no intersecting pair of any kind, by exact predicates.
void expect_certified_valid(const TriMesh& m, const ValidStart& s) {
  EXPECT_TRUE(certify_shell(m.V, s.top, m.F).valid());
  EXPECT_TRUE(s.inverted_tets.empty() && s.intersections.empty());
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
  const Eigen::MatrixXd P = offset_top(m.V, m.F, eta);
  const ExtrusionDirections d = extrusion_directions(m.V, m.F);
  ValidStartOptions options;
  options.fallback_length = eta;
  const ValidStart all = valid_start(m.V, m.F, P, d, {}, {}, options);
  expect_certified_valid(m, all);
  const int thinnings = static_cast<int>(std::lround(-std::log2(all.scale.minCoeff()))); // the most of one vertex
  ASSERT_GT(all.rounds, thinnings + 2) << "the case no longer thins as a front";
  // Rounds enough for every vertex's thinnings, fewer than the front needs in all: the same start.
  options.max_rounds = thinnings + 2;
  const ValidStart front = valid_start(m.V, m.F, P, d, {}, {}, options);
  expect_certified_valid(m, front);
  EXPECT_EQ(front.rounds, all.rounds);
  EXPECT_TRUE(front.scale == all.scale);
  // No thinning allowed: given up at the first check, with what it found reported.
  options.max_rounds = 1;
  const ValidStart none = valid_start(m.V, m.F, P, d, {}, {}, options);
  EXPECT_EQ(none.rounds, 1);
  EXPECT_FALSE(none.inverted_tets.empty());
}
