// The guard's building blocks on analytic cases: the per-tet step bound (the largest step keeping
// every tet positive), the volume barrier's gradient, extrusion directions.
#include <gshell/error.h>
#include <gshell/guard/extrusion_directions.h>
#include <gshell/guard/tet_step_bound.h>
#include <gshell/guard/volume_barrier.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/solver/rest_tets.h>

#include "kept_blocks.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/SparseCore>
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

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

// K separate tets, each the unit tet jittered by 0.2 (positively oriented), moving by `scale`
// times normal noise; tet t is vertices 4t..4t+3.
struct TetSoup {
  Eigen::MatrixXd X, D;
  Eigen::MatrixXi T;
};

TetSoup random_tets(int K, double scale, std::mt19937& rng) {
  std::normal_distribution<double> g(0, 1);
  TetSoup s{Eigen::MatrixXd(4 * K, 3), Eigen::MatrixXd(4 * K, 3), Eigen::MatrixXi(K, 4)};
  for (int t = 0; t < K; ++t) {
    Eigen::MatrixXd x = unit_tet();
    for (int i = 0; i < 4; ++i)
      for (int k = 0; k < 3; ++k) {
        x(i, k) += 0.2 * g(rng);
        s.D(4 * t + i, k) = scale * g(rng);
      }
    if (volume6(x) < 0) x.row(0).swap(x.row(1));
    s.X.middleRows(4 * t, 4) = x;
    s.T.row(t) << 4 * t, 4 * t + 1, 4 * t + 2, 4 * t + 3;
  }
  return s;
}

// Tet t's own bound, from its cubic alone.
double own_bound(const TetSoup& s, int t, double keep, double max_step) {
  Eigen::Vector3d p[4], d[4];
  for (int i = 0; i < 4; ++i) {
    p[i] = s.X.row(4 * t + i).transpose();
    d[i] = s.D.row(4 * t + i).transpose();
  }
  return cubic_step_bound(tet_volume_cubic(p, d), keep, max_step);
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

TEST(TetStepBound, TetsCuttingAStepAreThoseWhoseOwnRootIsBelowIt) {
  // The guarded solver holds the vertices of every tet that would cut a step of tau: exactly
  // the tets whose own bound is below tau, none skipped or merely translated, and among them the
  // one tet_step_bound names.
  std::mt19937 rng(4);
  const int K = 2000;
  TetSoup s = random_tets(K, 0.4, rng);
  std::vector<char> skip(K, 0);
  for (int t = 0; t < K; ++t) {
    if (t % 7 == 0) s.D.middleRows(4 * t, 4).rowwise() = s.D.row(4 * t); // translated: never cuts
    skip[t] = t % 11 == 0;
  }
  for (double tau : {0.05, 0.3, 1.0, 4.0}) {
    SCOPED_TRACE(tau);
    std::vector<int> expected;
    for (int t = 0; t < K; ++t)
      if (!skip[t] && t % 7 != 0 && own_bound(s, t, 0.1, tau) < tau) expected.push_back(t);
    const std::vector<int> cutting = tets_cutting_step(s.T, s.X, s.D, 0.1, tau, &skip);
    EXPECT_EQ(cutting, expected);
    EXPECT_FALSE(expected.empty());
    const TetStepBound least = tet_step_bound(s.T, s.X, s.D, 0.1, tau, &skip);
    EXPECT_TRUE(std::binary_search(cutting.begin(), cutting.end(), least.tet));
  }
  EXPECT_THROW(tets_cutting_step(s.T, s.X.topRows(8), s.D.topRows(8), 0.1, 1.0), InputError);
}

TEST(TetStepBound, ATurnByMoreThan143DegreesIsBoundedOnItsPathButKeptAtItsEnd) {
  // Turned by theta about an axis, the straight path's mid-point holds cos^2(theta / 2) of the
  // volume: below a tenth past 143.1 degrees. The end keeps all of it.
  const Eigen::MatrixXd X = unit_tet();
  for (double degrees : {140.0, 146.0, 180.0}) {
    SCOPED_TRACE(degrees);
    const Eigen::Matrix3d R = Eigen::AngleAxisd(degrees * M_PI / 180, Eigen::Vector3d(1, 2, 3).normalized()).matrix();
    const Eigen::MatrixXd turned = X * R.transpose();
    const double mid = std::pow(std::cos(degrees * M_PI / 360), 2);
    EXPECT_NEAR(volume6(0.5 * (X + turned)), mid * volume6(X), 1e-12);
    EXPECT_EQ(tet_step_bound(one_tet(), X, turned - X, 0.1, 1.0).step == 1.0, mid > 0.1);
    EXPECT_TRUE(tets_keep_volume(one_tet(), X, turned, 0.1));
  }
  // The end alone decides: flattened to a twentieth, or inverted, it is not kept; skipped, it is.
  Eigen::MatrixXd flat = X;
  flat(3, 2) = 0.05;
  EXPECT_TRUE(tets_keep_volume(one_tet(), X, flat, 0.04));
  EXPECT_FALSE(tets_keep_volume(one_tet(), X, flat, 0.1));
  flat(3, 2) = -1;
  EXPECT_FALSE(tets_keep_volume(one_tet(), X, flat, 0.1));
  const std::vector<char> skip = {1};
  EXPECT_TRUE(tets_keep_volume(one_tet(), X, flat, 0.1, &skip));
  EXPECT_TRUE(tets_keep_volume(one_tet(), flat, X, 0.1)); // not positive at the start: not bounded
  EXPECT_THROW(tets_keep_volume(one_tet(), X, X.topRows(3), 0.1), InputError);
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

// The unit tet with every coordinate moved by a normal deviate of 0.25.
Eigen::MatrixXd jittered_unit_tet(std::mt19937& rng) {
  std::normal_distribution<double> g(0, 1);
  Eigen::MatrixXd X = unit_tet();
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 3; ++k) X(i, k) += 0.25 * g(rng);
  return X;
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

TEST(VolumeBarrier, ATetFlatInExactArithmeticIsInfiniteWhateverRoundingSays) {
  // Corners on a tilted plane, the fourth one made from the first three in doubles: exactly flat
  // or inverted tets whose rounded determinant still comes out positive exist (a pose once ended
  // on one: its handles squeezed a tet between them flat). The barrier's domain is the exact
  // sign's, as the certificate's, so such a tet is outside it.
  const VolumeBarrier barrier(unit_rest(), 0.2);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coordinate(-1, 1), weight(0.1, 0.9);
  using Point = CGAL::Exact_predicates_inexact_constructions_kernel::Point_3;
  int found = 0;
  for (int trial = 0; trial < 100000 && found < 20; ++trial) {
    Eigen::MatrixXd X(4, 3);
    for (int k = 0; k < 3; ++k)
      for (int c = 0; c < 3; ++c) X(k, c) = coordinate(rng);
    const double a = weight(rng), b = weight(rng);
    X.row(3) = X.row(0) + a * (X.row(1) - X.row(0)) + b * (X.row(2) - X.row(0));
    if (!(barrier.relative_volume_of(X, 0) > 0)) continue;
    auto point = [&](int k) { return Point(X(k, 0), X(k, 1), X(k, 2)); };
    if (CGAL::orientation(point(0), point(1), point(2), point(3)) == CGAL::POSITIVE) continue;
    ++found;
    EXPECT_TRUE(std::isinf(barrier.energy(X))) << "trial " << trial << ": J rounds to " << barrier.relative_volume_of(X, 0);
  }
  EXPECT_GT(found, 0); // the case this test is about occurred
}

TEST(VolumeBarrier, AnotherThresholdActsAsABarrierMadeWithIt) {
  VolumeBarrier barrier(unit_rest(), 0.2);
  const VolumeBarrier made(unit_rest(), 0.05);
  Eigen::MatrixXd X = unit_tet();
  X(3, 2) = 0.03;
  barrier.set_j_hat(0.05);
  EXPECT_EQ(barrier.j_hat(), 0.05);
  EXPECT_EQ(barrier.energy(X), made.energy(X));
  X(3, 2) = 0.1; // above the new threshold, below the old one
  EXPECT_EQ(barrier.energy(X), 0.0);
  EXPECT_THROW(barrier.set_j_hat(0), InputError);
  EXPECT_THROW(barrier.set_j_hat(1.5), InputError);
  EXPECT_EQ(barrier.j_hat(), 0.05);
}

TEST(VolumeBarrier, GradientMatchesFiniteDifferences) {
  std::mt19937 rng(3);
  const VolumeBarrier barrier(unit_rest(), 0.5);
  int tested = 0;
  for (int trial = 0; trial < 200 && tested < 30; ++trial) {
    const Eigen::MatrixXd X = jittered_unit_tet(rng);
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

// The barrier's Hessian at X (12 x 12, one tet) as assembled by add_hessian.
Eigen::MatrixXd barrier_hessian(const VolumeBarrier& barrier, const Eigen::MatrixXd& X, bool projected) {
  std::vector<Eigen::Triplet<double>> t;
  barrier.add_hessian(X, 1.0, t, barrier.active_tets(X), projected);
  Eigen::SparseMatrix<double> H(12, 12);
  H.setFromTriplets(t.begin(), t.end());
  return Eigen::MatrixXd(H);
}

// The true Hessian of the barrier by central differences of its analytic gradient.
Eigen::MatrixXd finite_difference_hessian(const VolumeBarrier& barrier, const Eigen::MatrixXd& X, double h) {
  Eigen::MatrixXd H(12, 12);
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 3; ++k) {
      Eigen::MatrixXd Xp = X, Xm = X, Gp = Eigen::MatrixXd::Zero(4, 3), Gm = Gp;
      Xp(i, k) += h;
      Xm(i, k) -= h;
      barrier.add_gradient(Xp, 1.0, Gp, barrier.active_tets(Xp));
      barrier.add_gradient(Xm, 1.0, Gm, barrier.active_tets(Xm));
      const Eigen::MatrixXd d = (Gp - Gm) / (2 * h);
      for (int j = 0; j < 4; ++j)
        for (int l = 0; l < 3; ++l) H(3 * j + l, 3 * i + k) = d(j, l);
    }
  return H;
}

TEST(VolumeBarrier, ProjectedHessianIsPsdAndAboveTheTrueHessian) {
  // Projecting the whole Hessian onto its positive eigenvalues only raises its quadratic form:
  // v' H_proj v >= v' H v for every v, with H_proj positive semi-definite, and translations
  // cost nothing. (A wrong sign of the d^2J term breaks the inequality for some v.)
  std::mt19937 rng(5);
  std::normal_distribution<double> g(0, 1);
  const VolumeBarrier barrier(unit_rest(), 0.5);
  int tested = 0;
  for (int trial = 0; trial < 400 && tested < 20; ++trial) {
    const Eigen::MatrixXd X = jittered_unit_tet(rng);
    const double J = volume6(X);
    if (!(J > 0.05 && J < 0.45)) continue;
    ++tested;
    const Eigen::MatrixXd Hp = barrier_hessian(barrier, X, true), H = finite_difference_hessian(barrier, X, 1e-6);
    const double scale = std::max(1.0, H.cwiseAbs().maxCoeff());
    EXPECT_LT((H - H.transpose()).cwiseAbs().maxCoeff(), 1e-5 * scale);
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Hp);
    EXPECT_GT(eig.eigenvalues().minCoeff(), -1e-9 * scale) << "trial " << trial;
    for (int k = 0; k < 20; ++k) {
      const Eigen::VectorXd v = Eigen::VectorXd::NullaryExpr(12, [&] { return g(rng); });
      EXPECT_GE(v.dot(Hp * v), v.dot(H * v) - 1e-5 * scale * v.squaredNorm()) << "trial " << trial;
    }
    for (int axis = 0; axis < 3; ++axis) {
      Eigen::VectorXd shift = Eigen::VectorXd::Zero(12);
      for (int i = 0; i < 4; ++i) shift[3 * i + axis] = 1;
      EXPECT_LT((Hp * shift).norm(), 1e-9 * scale);
    }
  }
  EXPECT_GE(tested, 10);
}

TEST(VolumeBarrier, HessianOfKeptVerticesIsTheirBlocksInTheSameOrder) {
  // A solver holding some vertices asks only for the blocks between the others: those of the whole
  // Hessian, the same values in the same order (its assembly sums them in that order). Tets share
  // vertices here so that a tet keeps 0 to 4 corners.
  std::mt19937 rng(8);
  std::normal_distribution<double> g(0, 1);
  const int K = 300, n = 120;
  Eigen::MatrixXi T(K, 4);
  Eigen::MatrixXd rest(n, 3);
  for (int v = 0; v < n; ++v) rest.row(v) << g(rng), g(rng), g(rng);
  std::uniform_int_distribution<int> pick(0, n - 1);
  for (int t = 0; t < K; ++t) {
    std::array<int, 4> c{};
    do {
      for (int& v : c) v = pick(rng);
      std::sort(c.begin(), c.end());
    } while (std::adjacent_find(c.begin(), c.end()) != c.end());
    if (t == 0) c = {0, 3, 6, 9}; // no corner kept below: the tet writes nothing
    if (volume6(rest(std::vector<int>(c.begin(), c.end()), Eigen::all)) < 0) std::swap(c[0], c[1]);
    T.row(t) << c[0], c[1], c[2], c[3];
  }
  // Squashed along z: every tet at a tenth of its volume, inside the barrier.
  Eigen::MatrixXd X = rest;
  X.col(2) *= 0.1;
  const VolumeBarrier barrier(rest_tets_from_positions(rest, T), 0.3);
  const std::vector<int> active = barrier.active_tets(X);
  ASSERT_EQ(static_cast<int>(active.size()), K);
  std::vector<char> kept(n, 0);
  for (int v = 0; v < n; ++v) kept[v] = v % 3 != 0;
  for (bool projected : {false, true}) {
    std::vector<Eigen::Triplet<double>> all, some;
    barrier.add_hessian(X, 0.7, all, active, projected);
    barrier.add_hessian(X, 0.7, some, active, projected, &kept);
    ASSERT_EQ(all.size(), 144u * K);
    EXPECT_LT(some.size(), all.size());
    EXPECT_TRUE(test::same_triplets(some, test::kept_blocks(all, kept))) << "projected " << projected;
  }
  const std::vector<char> short_flags(n - 1, 1);
  std::vector<Eigen::Triplet<double>> H;
  EXPECT_THROW(barrier.add_hessian(X, 1.0, H, active, true, &short_flags), InputError);
}

TEST(VolumeBarrier, ProjectedHessianIsTheEigenProjectionOfTheTrueHessian) {
  // add_hessian projects each tet's Hessian in its edge coordinates from a closed-form
  // eigensystem (the SVD of the edge matrix). Against a general symmetric eigensolver applied to
  // the true Hessian (central differences of the gradient, taken to edge coordinates with x_0
  // held), over tets from nearly flat to half the barrier's reach, turned and mirrored: equal up
  // to the differences' error. A wrong mode or sign in the closed form changes whole eigenvalues.
  std::mt19937 rng(17);
  std::normal_distribution<double> g(0, 1);
  const VolumeBarrier barrier(unit_rest(), 0.5);
  // x = R e: x_0 = 0, x_k = e_k (12 x 9); e = P x (9 x 12).
  Eigen::MatrixXd R = Eigen::MatrixXd::Zero(12, 9), P = Eigen::MatrixXd::Zero(9, 12);
  for (int k = 0; k < 3; ++k)
    for (int i = 0; i < 3; ++i) {
      R(3 * (k + 1) + i, 3 * k + i) = 1;
      P(3 * k + i, 3 * (k + 1) + i) = 1;
      P(3 * k + i, i) = -1;
    }
  int tested = 0;
  for (int trial = 0; trial < 2000 && tested < 30; ++trial) {
    Eigen::MatrixXd X = jittered_unit_tet(rng);
    if (trial % 3 == 0) X.col(2) *= 0.05 + 0.2 * std::abs(g(rng)); // nearly flat
    if (trial % 2 == 0) { // mirrored, then two corners swapped to keep it positive
      X.col(0) *= -1;
      X.row(1).swap(X.row(2));
    }
    const double J = volume6(X);
    if (!(J > 0.002 && J < 0.25)) continue;
    ++tested;
    const Eigen::MatrixXd Hp = barrier_hessian(barrier, X, true);
    Eigen::MatrixXd H = finite_difference_hessian(barrier, X, 1e-7 * std::max(J, 0.01));
    H = 0.5 * (H + H.transpose()).eval();
    const Eigen::MatrixXd He = R.transpose() * H * R;
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(He);
    const Eigen::MatrixXd He_plus =
        eig.eigenvectors() * eig.eigenvalues().cwiseMax(0).asDiagonal() * eig.eigenvectors().transpose();
    const Eigen::MatrixXd reference = P.transpose() * He_plus * P;
    const double scale = std::max(1.0, H.cwiseAbs().maxCoeff());
    EXPECT_LT((Hp - reference).cwiseAbs().maxCoeff(), 1e-5 * scale) << "trial " << trial << " J " << J;
  }
  EXPECT_GE(tested, 20);
}

TEST(VolumeBarrier, ProjectedHessianResistsTurningANearlyFlatTetFlatter) {
  // A nearly flat tet and motions orthogonal to grad J (first order: no change of J) along which
  // the true barrier curves up (they flatten it at second order): the Gauss-Newton part sees
  // nothing there, the projected Hessian at least the true curvature.
  Eigen::MatrixXd X = unit_tet();
  X(3, 2) = 0.02; // J = 0.02, deep inside j_hat = 0.1
  const VolumeBarrier barrier(unit_rest(), 0.1);
  const Eigen::MatrixXd Hp = barrier_hessian(barrier, X, true), Hg = barrier_hessian(barrier, X, false);
  const Eigen::MatrixXd H = finite_difference_hessian(barrier, X, 1e-8);
  Eigen::Vector3d grad[4];
  barrier.relative_volume_gradient(X, 0, grad);
  Eigen::VectorXd gJ(12);
  for (int i = 0; i < 4; ++i) gJ.segment<3>(3 * i) = grad[i];
  std::mt19937 rng(2);
  std::normal_distribution<double> g(0, 1);
  int found = 0;
  for (int k = 0; k < 50; ++k) {
    Eigen::VectorXd v = Eigen::VectorXd::NullaryExpr(12, [&] { return g(rng); });
    v -= gJ * (gJ.dot(v) / gJ.squaredNorm());
    const double curvature = v.dot(H * v);
    if (!(curvature > 1e-3 * v.squaredNorm() * H.cwiseAbs().maxCoeff())) continue;
    ++found;
    EXPECT_NEAR(v.dot(Hg * v), 0.0, 1e-9 * curvature);
    EXPECT_GE(v.dot(Hp * v), curvature * (1 - 1e-4));
  }
  EXPECT_GE(found, 5);
}

TEST(TetStepBound, SameBitsWithOneThreadAndMany) {
  // The bound of each tet does not depend on which tets were looked at before it (the thread
  // schedule), so the minimum is the same bits however the tets are split among threads.
  std::mt19937 rng(11);
  const auto [X, D, T] = random_tets(20000, 1.0, rng);
  const TetStepBound many = tet_step_bound(T, X, D, 0.1, 1.0);
  TetStepBound one;
  tbb::task_arena(1).execute([&] { one = tet_step_bound(T, X, D, 0.1, 1.0); });
  ASSERT_LT(many.step, 1.0);
  EXPECT_EQ(one.step, many.step);
  EXPECT_EQ(one.tet, many.tet);
}

TEST(TetStepBound, EveryTetsBoundIsItsCubicsFirstRoot) {
  // tet_step_bound settles most tets without a root search (the Bernstein coefficients of their
  // volume cubic stay above the fraction kept); that shortcut must not change any tet's answer.
  // Each tet alone, against cubic_step_bound of its cubic, over motions from tiny (every tet
  // kept) through ones that come within a hair of the fraction to ones that flatten the tet.
  std::mt19937 rng(5);
  std::normal_distribution<double> g(0, 1);
  int kept = 0, limited = 0;
  for (double scale : {1e-3, 0.1, 0.5, 1.0, 3.0})
    for (int trial = 0; trial < 2000; ++trial) {
      Eigen::MatrixXd x = unit_tet(), D(4, 3);
      for (int i = 0; i < 4; ++i)
        for (int k = 0; k < 3; ++k) {
          x(i, k) += 0.2 * g(rng);
          D(i, k) = scale * g(rng);
        }
      if (volume6(x) < 0) x.row(0).swap(x.row(1));
      for (double max_step : {1.0, 0.37}) {
        Eigen::Vector3d p[4], d[4];
        for (int i = 0; i < 4; ++i) {
          p[i] = x.row(i).transpose();
          d[i] = D.row(i).transpose();
        }
        const double expected = cubic_step_bound(tet_volume_cubic(p, d), 0.1, max_step);
        const TetStepBound b = tet_step_bound(one_tet(), x, D, 0.1, max_step);
        ASSERT_EQ(b.step, expected) << "scale " << scale << " trial " << trial << " max_step " << max_step;
        ASSERT_EQ(b.tet, expected < max_step ? 0 : -1);
        (expected < max_step ? limited : kept) += 1;
      }
    }
  EXPECT_GT(kept, 1000);
  EXPECT_GT(limited, 1000);
}

TEST(TetStepBound, ManyTetsAtOnceGiveTheLeastOfTheirCubicsRoots) {
  // The same through the lanes in which tet_step_bound settles tets in batches: the bound over
  // many tets is the least per-tet root, and it names the first tet that has it.
  std::mt19937 rng(9);
  for (double scale : {0.05, 0.3, 1.0}) {
    const int K = 3000;
    const TetSoup soup = random_tets(K, scale, rng);
    const auto& [X, D, T] = soup;
    double least = 0.8;
    int first = -1;
    for (int t = 0; t < K; ++t) {
      const double s = own_bound(soup, t, 0.1, 0.8);
      if (s < least) {
        least = s;
        first = t;
      }
    }
    const TetStepBound b = tet_step_bound(T, X, D, 0.1, 0.8);
    EXPECT_EQ(b.step, least) << "scale " << scale;
    EXPECT_EQ(b.tet, first) << "scale " << scale;
  }
}

TEST(TetStepBound, FewTetsAmongManyVerticesGiveTheSameBound) {
  // A guard repairing a small region of a large shell bounds a few tets over many vertices; they
  // then read X and D where they are instead of an interleaved copy: same bound, same tet.
  std::mt19937 rng(10);
  const int K = 200;
  const TetSoup soup = random_tets(K, 0.3, rng);
  const TetStepBound compact = tet_step_bound(soup.T, soup.X, soup.D, 0.1, 0.8);
  ASSERT_LT(compact.step, 0.8);
  const int extra = 10 * static_cast<int>(soup.X.rows()); // vertices no tet uses, first
  Eigen::MatrixXd X = Eigen::MatrixXd::Random(extra + soup.X.rows(), 3), D = X;
  X.bottomRows(soup.X.rows()) = soup.X;
  D.bottomRows(soup.D.rows()) = soup.D;
  const Eigen::MatrixXi T = soup.T.array() + extra;
  const TetStepBound spread = tet_step_bound(T, X, D, 0.1, 0.8);
  EXPECT_EQ(spread.step, compact.step);
  EXPECT_EQ(spread.tet, compact.tet);
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

TEST(ExtrusionDirections, RimWallCuttingThroughItsOwnFaceIsBlocked) {
  // Vertex 0 at the origin on the rim of an open fan of two faces: (0, 1, 2) along the boundary
  // edge to vertex 1 = (1, 0, 0), and (0, 2, 3), which reaches over the x > 0, z > 0 quarter of
  // the xz plane (it contains (0.5, 0, 0.5)); (0, 3) is the other boundary edge. Lifted along +z
  // the wall over edge (0, 1) is that quarter near vertex 0, so it crosses face (0, 2, 3) however
  // thin the layer; along -z both walls stay clear; and once the fan is closed (no rim at
  // vertex 0) nothing is blocked.
  Eigen::MatrixXd V(4, 3);
  V << 0, 0, 0, //
      1, 0, 0,  //
      0.5, -1, 0.5, //
      0.5, 1, 0.5;
  Eigen::MatrixXi F(2, 3);
  F << 0, 1, 2, //
      0, 2, 3;
  Eigen::MatrixXd up = Eigen::MatrixXd::Zero(4, 3), down = up;
  up.col(2).setOnes();
  down.col(2).setConstant(-1);
  EXPECT_EQ(rim_vertices_with_blocked_walls(V, F, up, {0}), std::vector<int>{0});
  EXPECT_TRUE(rim_vertices_with_blocked_walls(V, F, down, {0}).empty());
  Eigen::MatrixXi closed(3, 3);
  closed << F, Eigen::RowVector3i(0, 3, 1);
  EXPECT_TRUE(rim_vertices_with_blocked_walls(V, closed, up, {0}).empty());
}

} // namespace
} // namespace gshell
