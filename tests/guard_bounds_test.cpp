// The guard's building blocks on analytic cases: the per-tet step bound (the largest step keeping
// every tet positive), the volume barrier's gradient, extrusion directions.
#include <gshell/error.h>
#include <gshell/guard/extrusion_directions.h>
#include <gshell/guard/tet_step_bound.h>
#include <gshell/guard/volume_barrier.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/solver/rest_tets.h>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace gshell {
namespace {

Eigen::MatrixXd unit_tet() {
  Eigen::MatrixXd X(4, 3);
  X << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  return X;
}

Eigen::MatrixXi one_tet() { return (Eigen::MatrixXi(1, 4) << 0, 1, 2, 3).finished(); }

double volume6(const Eigen::MatrixXd& X) {
  const Eigen::Vector3d a = X.row(1) - X.row(0), b = X.row(2) - X.row(0), c = X.row(3) - X.row(0);
  return a.dot(b.cross(c));
}

TEST(TetStepBound, ApexPushedThroughTheBaseStopsBeforeTheCollapse) {
  // The apex reaches the base plane at s = 1/speed: volume (1 - speed s).
  for (double speed : {0.6, 1.0, 3.0, 1e3}) {
    Eigen::MatrixXd D = Eigen::MatrixXd::Zero(4, 3);
    D(3, 2) = -speed;
    const double collapse = 1 / speed;
    const TetStepBound b = tet_step_bound(one_tet(), unit_tet(), D, 0.0, 2.0);
    EXPECT_LT(b.step, collapse);
    EXPECT_GT(b.step, collapse * (1 - 1e-9)); // tight, not just safe
    EXPECT_EQ(b.tet, 0);
    // With a kept fraction, it stops where the volume has fallen to that fraction.
    const TetStepBound half = tet_step_bound(one_tet(), unit_tet(), D, 0.5, 2.0);
    EXPECT_NEAR(half.step, 0.5 * collapse, 1e-9 * collapse);
    EXPECT_LT(half.step, 0.5 * collapse);
  }
  Eigen::MatrixXd slow = Eigen::MatrixXd::Zero(4, 3);
  slow(3, 2) = -0.4; // collapses at 2.5, beyond the largest step asked for
  const TetStepBound b = tet_step_bound(one_tet(), unit_tet(), slow, 0.0, 2.0);
  EXPECT_EQ(b.step, 2.0);
  EXPECT_EQ(b.tet, -1);
}

TEST(TetStepBound, TripleRootOfAUniformShrinkIsNotMissed) {
  // Every edge shrinks to zero at s = 1: volume (1 - s)^3, a triple root.
  Eigen::MatrixXd D = -unit_tet();
  const TetStepBound b = tet_step_bound(one_tet(), unit_tet(), D, 0.0, 5.0);
  EXPECT_LE(b.step, 1.0);
  EXPECT_GT(b.step, 1 - 1e-4);
}

TEST(TetStepBound, GrazingTouchOfZeroVolumeIsNotSteppedOver) {
  // Volumes that touch zero for an instant and recover (double root), or flatten in a triple
  // root: a sign test at the ends of the interval would step over both.
  const std::array<double, 4> a = {1.0, -2.0, 1.0, 0.0}; // (1 - s)^2
  EXPECT_LT(cubic_step_bound(a, 0.0, 2.0), 1.0);
  EXPECT_GT(cubic_step_bound(a, 0.0, 2.0), 1 - 1e-6);
  const std::array<double, 4> b = {1.0, -3.0, 3.0, -1.0}; // (1 - s)^3
  EXPECT_LT(cubic_step_bound(b, 0.0, 2.0), 1.0);
  const std::array<double, 4> c = {1.0, 1.0, 1.0, 1.0}; // never falls
  EXPECT_EQ(cubic_step_bound(c, 0.0, 2.0), 2.0);
  const std::array<double, 4> d = {1.0, -1.0, 0.0, 0.0}; // linear, root at 1
  EXPECT_NEAR(cubic_step_bound(d, 0.9, 5.0), 0.1, 1e-12);
}

TEST(TetStepBound, RandomMotionsKeepEveryTetAboveTheFraction) {
  std::mt19937 rng(7);
  std::normal_distribution<double> g(0, 1);
  for (int trial = 0; trial < 2000; ++trial) {
    Eigen::MatrixXd X = unit_tet(), D(4, 3);
    for (int i = 0; i < 4; ++i)
      for (int k = 0; k < 3; ++k) {
        X(i, k) += 0.3 * g(rng);
        D(i, k) = 2 * g(rng);
      }
    if (volume6(X) <= 0) X.row(0).swap(X.row(1));
    const double v0 = volume6(X), keep = 0.1;
    const TetStepBound b = tet_step_bound(one_tet(), X, D, keep, 1.0);
    ASSERT_GE(b.step, 0.0);
    for (int k = 0; k <= 200; ++k) {
      const double s = b.step * k / 200.0;
      ASSERT_GT(volume6(X + s * D), keep * v0 * (1 - 1e-9)) << "trial " << trial << " s " << s;
    }
    if (b.step < 1.0) // the bound is the root: just past it the volume is at the fraction
      EXPECT_LE(volume6(X + (b.step + 1e-6) * D), keep * v0 + 1e-5 * std::abs(v0) + 1e-9) << "trial " << trial;
  }
}

TEST(TetStepBound, SkippedAndTranslatedTetsDoNotLimit) {
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(4, 3);
  D(3, 2) = -1;
  const std::vector<char> skip = {1};
  EXPECT_EQ(tet_step_bound(one_tet(), unit_tet(), D, 0.0, 3.0, &skip).step, 3.0);
  const Eigen::MatrixXd shift = Eigen::MatrixXd::Constant(4, 3, -5.0);
  EXPECT_EQ(tet_step_bound(one_tet(), unit_tet(), shift, 0.0, 3.0).step, 3.0);
}

RestTets unit_rest() { return rest_tets_from_positions(unit_tet(), one_tet()); }

// tet_step_bound reads X and D through T's ids: a motion for fewer vertices, or a tet list of
// another mesh, must be refused rather than read out of bounds.
TEST(TetStepBound, MismatchedShapesAndIdsAreInputErrors) {
  Eigen::MatrixXd X(4, 3);
  X << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  Eigen::MatrixXi T(1, 4);
  T << 0, 1, 2, 3;
  const Eigen::MatrixXd D = Eigen::MatrixXd::Zero(4, 3);
  EXPECT_THROW(tet_step_bound(T, X, D.topRows(3), 0.5, 1), InputError);
  Eigen::MatrixXi T_far = T;
  T_far(0, 3) = 4;
  EXPECT_THROW(tet_step_bound(T_far, X, D, 0.5, 1), InputError);
  const std::vector<char> two_flags(2, 0);
  EXPECT_THROW(tet_step_bound(T, X, D, 0.5, 1, &two_flags), InputError);
  EXPECT_EQ(tet_step_bound(T, X, D, 0.5, 1).step, 1);
}

TEST(VolumeBarrier, ZeroAboveTheThresholdInfiniteWhenFlat) {
  const VolumeBarrier barrier(unit_rest(), 0.2);
  EXPECT_EQ(barrier.energy(unit_tet()), 0.0);
  Eigen::MatrixXd X = unit_tet();
  X(3, 2) = 0.1; // J = 0.1
  EXPECT_GT(barrier.energy(X), 0.0);
  X(3, 2) = 0.01;
  const double e = barrier.energy(X);
  X(3, 2) = 0.001;
  EXPECT_GT(barrier.energy(X), e); // grows towards collapse
  X(3, 2) = 0;
  EXPECT_TRUE(std::isinf(barrier.energy(X)));
  X(3, 2) = -0.1;
  EXPECT_TRUE(std::isinf(barrier.energy(X)));
}

TEST(VolumeBarrier, GradientMatchesFiniteDifferences) {
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0, 1);
  const VolumeBarrier barrier(unit_rest(), 0.5);
  int tested = 0;
  for (int trial = 0; trial < 200 && tested < 30; ++trial) {
    Eigen::MatrixXd X = unit_tet();
    for (int i = 0; i < 4; ++i)
      for (int k = 0; k < 3; ++k) X(i, k) += 0.25 * g(rng);
    const double J = volume6(X) / 1.0;
    if (!(J > 0.05 && J < 0.45)) continue; // inside the barrier, away from its kink
    ++tested;
    Eigen::MatrixXd G = Eigen::MatrixXd::Zero(4, 3);
    barrier.add_gradient(X, 1.0, G, barrier.active_tets(X));
    const double h = 1e-6;
    for (int i = 0; i < 4; ++i)
      for (int k = 0; k < 3; ++k) {
        Eigen::MatrixXd Xp = X, Xm = X;
        Xp(i, k) += h;
        Xm(i, k) -= h;
        const double fd = (barrier.energy(Xp) - barrier.energy(Xm)) / (2 * h);
        EXPECT_NEAR(G(i, k), fd, 1e-6 * (1 + std::abs(fd))) << "trial " << trial;
      }
  }
  EXPECT_GE(tested, 10);
}

TEST(ExtrusionDirections, ConvexSurfacesKeepTheirNormals) {
  const TriMesh sphere = make_sphere(2);
  const ExtrusionDirections d = extrusion_directions(sphere.V, sphere.F);
  EXPECT_TRUE(d.unextrudable.empty());
  for (int i = 0; i < sphere.V.rows(); ++i) {
    EXPECT_NEAR(d.direction.row(i).dot(sphere.V.row(i).normalized()), 1.0, 1e-3);
    EXPECT_GT(d.margin[i], 0.9);
  }
}

TEST(ExtrusionDirections, SharpCornerGetsTheMaxMinDirection) {
  // A cube corner: the three face normals are the axes; the best direction is their diagonal
  // with margin 1/sqrt(3). A skewed triangulation tilts the area-weighted normal, not this one.
  Eigen::MatrixXd V(4, 3);
  V << 0, 0, 0, -3, 0, 0, 0, -1, 0, 0, 0, -1;
  Eigen::MatrixXi F(3, 3);
  F << 0, 1, 2, 0, 2, 3, 0, 3, 1; // outward normals +z, +x, +y
  const ExtrusionDirections d = extrusion_directions(V, F, 0.99);
  EXPECT_NEAR(d.margin[0], 1 / std::sqrt(3.0), 1e-12);
  EXPECT_NEAR(d.direction(0, 0), 1 / std::sqrt(3.0), 1e-12);
  EXPECT_NEAR(d.direction(0, 1), 1 / std::sqrt(3.0), 1e-12);
}

TEST(ExtrusionDirections, FacesNoDirectionSeesAreReported) {
  // A star whose face normals surround the origin: no direction sees all of them.
  Eigen::MatrixXd V(8, 3);
  V << 0.00, 0.00, 0.00, 0.86, 0.12, 1.21, 0.22, 1.09, -1.44, 0.32, 1.40, -1.20, -0.95, -0.10, 1.35, -0.83, 0.13,
      -0.11, 0.29, -1.01, -0.81, 0.03, -0.65, -0.50;
  Eigen::MatrixXi F(7, 3);
  for (int i = 0; i < 7; ++i) F.row(i) << 0, i + 1, (i + 1) % 7 + 1;
  const ExtrusionDirections d = extrusion_directions(V, F);
  ASSERT_EQ(d.unextrudable, std::vector<int>{0});
  EXPECT_LT(d.margin[0], -0.3);
  // Brute force over the sphere agrees that nothing does better.
  std::mt19937 rng(5);
  std::normal_distribution<double> g(0, 1);
  double best = -2;
  for (int s = 0; s < 200000; ++s) {
    const Eigen::Vector3d dir = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    double m = 2;
    for (int f = 0; f < 7; ++f) {
      const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
      m = std::min(m, (b - a).cross(c - a).normalized().dot(dir));
    }
    best = std::max(best, m);
  }
  EXPECT_LE(best, d.margin[0] + 1e-9);
  EXPECT_GT(best, d.margin[0] - 0.02);
}

} // namespace
} // namespace gshell
