// Contact handling between boundary triangles of a shell: primitive distances against sampling,
// barrier derivatives against finite differences, conservative CCD on motions with known contact
// times, the candidate list against brute force, and shells stepped along colliding motions that
// stay free of intersections by exact tests.
#include <gshell/error.h>
#include <gshell/guard/contact_barrier.h>
#include <gshell/guard/contact_guard.h>
#include <gshell/guard/pair_ccd.h>
#include <gshell/guard/primitive_distance.h>
#include <gshell/quality/shell_boundary.h>
#include <gshell/quality/triangle_intersections.h>
#include <gshell/shell/offset_shell.h>

#include "core_test_meshes.h"
#include "kept_blocks.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <set>

using namespace gshell;

namespace {

using Vec3 = Eigen::Vector3d;

PairPoints pts(Vec3 a, Vec3 b, Vec3 c, Vec3 d) { return {a, b, c, d}; }

PairPoints moved(const PairPoints& x, const PairPoints& dx, double t) {
  PairPoints y;
  for (int k = 0; k < 4; ++k) y[k] = x[k] + t * dx[k];
  return y;
}

PairPoints perturbed(const PairPoints& x, int coordinate, double h) {
  PairPoints y = x;
  y[coordinate / 3][coordinate % 3] += h;
  return y;
}

// Smallest distance between sampled points of the two primitives: an upper bound of the true
// distance that comes within the grid spacing times the primitives' size.
double sampled_distance(PairKind kind, const PairPoints& x, int n) {
  double best = std::numeric_limits<double>::infinity();
  if (kind == PairKind::PointTriangle) {
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) {
        const double u = double(i) / n, v = double(j) / n;
        best = std::min(best, (x[0] - (x[1] + u * (x[2] - x[1]) + v * (x[3] - x[1]))).norm());
      }
  } else {
    for (int i = 0; i <= n; ++i)
      for (int j = 0; j <= n; ++j) {
        const double s = double(i) / n, t = double(j) / n;
        best = std::min(best, ((x[0] + s * (x[1] - x[0])) - (x[2] + t * (x[3] - x[2]))).norm());
      }
  }
  return best;
}

double extent(const PairPoints& x) {
  double e = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) e = std::max(e, (x[i] - x[j]).norm());
  return e;
}

PairPoints random_points(std::mt19937& rng, double scale = 1) {
  std::uniform_real_distribution<double> u(-scale, scale);
  PairPoints x;
  for (auto& p : x) p = Vec3(u(rng), u(rng), u(rng));
  return x;
}

// Named configurations realising every closest-feature case, near-degenerate ones included.
struct Case {
  const char* name;
  PairKind kind;
  PairPoints x;
  ClosestFeatures features;
};

std::vector<Case> feature_cases() {
  const Vec3 t0(0, 0, 0), t1(1, 0, 0), t2(0, 1, 0);
  return {
      {"point above face", PairKind::PointTriangle, pts({0.2, 0.3, 0.4}, t0, t1, t2), ClosestFeatures::PointFace},
      {"point below face", PairKind::PointTriangle, pts({0.3, 0.3, -0.2}, t0, t1, t2), ClosestFeatures::PointFace},
      {"point beside edge", PairKind::PointTriangle, pts({0.5, -0.3, 0.2}, t0, t1, t2), ClosestFeatures::PointEdge},
      {"point beside hypotenuse", PairKind::PointTriangle, pts({0.7, 0.6, 0.1}, t0, t1, t2), ClosestFeatures::PointEdge},
      {"point beyond corner", PairKind::PointTriangle, pts({1.3, -0.2, 0.3}, t0, t1, t2), ClosestFeatures::PointPoint},
      {"point beyond origin", PairKind::PointTriangle, pts({-0.3, -0.2, -0.3}, t0, t1, t2), ClosestFeatures::PointPoint},
      {"point over sliver", PairKind::PointTriangle, pts({0.5, 0.005, 0.3}, t0, t1, {0.5, 0.01, 0}),
       ClosestFeatures::PointFace},
      {"crossing edges", PairKind::EdgeEdge, pts({0, -1, 0.3}, {0.2, 1, 0.35}, {-1, 0.1, 0}, {1, 0, 0}),
       ClosestFeatures::EdgeEdge},
      {"edge end against edge", PairKind::EdgeEdge, pts({0.2, 0.4, 0.3}, {0.3, 2, 0.5}, {-1, 0, 0}, {1, 0, 0}),
       ClosestFeatures::PointEdge},
      {"edge against edge end", PairKind::EdgeEdge, pts({-1, 0, 0}, {1, 0.1, 0}, {0.3, 0.5, 0.2}, {0.4, 2, 0.3}),
       ClosestFeatures::PointEdge},
      {"edge ends", PairKind::EdgeEdge, pts({0, 0, 0}, {-1, 0, 0}, {1, 0.3, 0.2}, {2, 1, 0}), ClosestFeatures::PointPoint},
      {"nearly parallel edges", PairKind::EdgeEdge, pts({-1, -0.01, 0}, {1, 0.01, 0}, {-1, 0.01, 0.3}, {1, -0.01, 0.3}),
       ClosestFeatures::EdgeEdge},
  };
}

// Exactly parallel segments: the distance is right, but its derivatives jump there (the kink the
// edge-edge mollifier smooths), so these stay out of the finite-difference tests.
std::vector<Case> parallel_cases() {
  return {
      {"parallel offset edges", PairKind::EdgeEdge, pts({0, 0, 0}, {1, 0, 0}, {0.5, 0.3, 0.2}, {1.5, 0.3, 0.2}),
       ClosestFeatures::PointEdge},
      {"parallel overlapping edges", PairKind::EdgeEdge, pts({0, 0, 0}, {2, 0, 0}, {0.5, 0.3, 0.2}, {1.5, 0.3, 0.2}),
       ClosestFeatures::PointEdge},
  };
}

} // namespace

// ---- distances -----------------------------------------------------------------------------

TEST(PrimitiveDistance, FeatureCasesAreRecognisedAndMatchSampling) {
  std::vector<Case> cases = feature_cases();
  for (const Case& c : parallel_cases()) cases.push_back(c);
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const PairDistance d = pair_distance(c.kind, c.x);
    EXPECT_EQ(d.features, c.features);
    const double sampled = sampled_distance(c.kind, c.x, 600);
    EXPECT_LE(std::sqrt(d.squared), sampled + 1e-12);
    EXPECT_GE(std::sqrt(d.squared), sampled - 3 * extent(c.x) / 600);
  }
}

TEST(PrimitiveDistance, RandomPairsNeverExceedSampledDistance) {
  std::mt19937 rng(7);
  for (int i = 0; i < 200; ++i) {
    for (PairKind kind : {PairKind::PointTriangle, PairKind::EdgeEdge}) {
      const PairPoints x = random_points(rng);
      const PairDistance d = pair_distance(kind, x);
      const double sampled = sampled_distance(kind, x, 120);
      ASSERT_LE(std::sqrt(d.squared), sampled + 1e-12) << i;
      ASSERT_GE(std::sqrt(d.squared), sampled - 3 * extent(x) / 120) << i;
    }
  }
}

TEST(PrimitiveDistance, ExactValuesOfSimpleCases) {
  const Vec3 t0(0, 0, 0), t1(1, 0, 0), t2(0, 1, 0);
  EXPECT_NEAR(point_triangle_distance(pts({0.2, 0.3, 0.4}, t0, t1, t2)).squared, 0.16, 1e-15);
  EXPECT_NEAR(point_triangle_distance(pts({0.5, -0.3, 0.4}, t0, t1, t2)).squared, 0.25, 1e-15);
  EXPECT_NEAR(point_triangle_distance(pts({2, 0, 0}, t0, t1, t2)).squared, 1, 1e-15);
  // Skew perpendicular lines at height 0.5; parallel edges 0.3 apart; collinear disjoint edges.
  EXPECT_NEAR(edge_edge_distance(pts({-1, 0, 0}, {1, 0, 0}, {0, -1, 0.5}, {0, 1, 0.5})).squared, 0.25, 1e-15);
  EXPECT_NEAR(edge_edge_distance(pts({0, 0, 0}, {1, 0, 0}, {0.5, 0.3, 0}, {3, 0.3, 0})).squared, 0.09, 1e-15);
  EXPECT_NEAR(edge_edge_distance(pts({0, 0, 0}, {1, 0, 0}, {1.5, 0, 0}, {3, 0, 0})).squared, 0.25, 1e-15);
  // Exactly parallel, touching along a stretch: 0.
  EXPECT_EQ(edge_edge_distance(pts({0, 0, 0}, {1, 0, 0}, {0.5, 0, 0}, {3, 0, 0})).squared, 0);
}

TEST(PrimitiveDistance, NearlyParallelEdgesAndFlatTrianglesStayAccurate) {
  // Edges crossing at angles down to 1e-9 rad: the distance is the height between them.
  for (double angle : {1e-2, 1e-5, 1e-7, 1e-9}) {
    const double h = 1e-3;
    const PairPoints x = pts({-1, 0, 0}, {1, 0, 0}, {-std::cos(angle), -std::sin(angle), h},
                             {std::cos(angle), std::sin(angle), h});
    EXPECT_NEAR(std::sqrt(edge_edge_distance(x).squared), h, 1e-12) << angle;
  }
  // A point over a needle-thin triangle (height 1e-9): its distance to the plane.
  const PairPoints y = pts({0.5, 2e-10, 0.25}, {0, 0, 0}, {1, 0, 0}, {0.5, 1e-9, 0});
  EXPECT_NEAR(std::sqrt(point_triangle_distance(y).squared), 0.25, 1e-12);
}

TEST(PrimitiveDistance, GradientAndHessianMatchFiniteDifferences) {
  for (const Case& c : feature_cases()) {
    SCOPED_TRACE(c.name);
    const PairDistance d = pair_distance(c.kind, c.x);
    const Vector12d g = squared_distance_gradient(c.x, d);
    const Matrix12d h = squared_distance_hessian(c.x, d);
    const double step = 1e-6;
    for (int i = 0; i < 12; ++i) {
      const PairPoints xp = perturbed(c.x, i, step), xm = perturbed(c.x, i, -step);
      const double fd = (pair_distance(c.kind, xp).squared - pair_distance(c.kind, xm).squared) / (2 * step);
      EXPECT_NEAR(g[i], fd, 1e-7 * std::max(1.0, std::abs(fd))) << "coordinate " << i;
      const Vector12d gd = (squared_distance_gradient(xp, pair_distance(c.kind, xp)) -
                            squared_distance_gradient(xm, pair_distance(c.kind, xm))) / (2 * step);
      // The sliver's Hessian is large (its closest point slides fast): relative tolerance.
      const double tol = 1e-5 * std::max(1.0, h.cwiseAbs().maxCoeff());
      for (int j = 0; j < 12; ++j) EXPECT_NEAR(h(j, i), gd[j], tol) << "entry " << j << ", " << i;
    }
  }
}

// ---- barrier -------------------------------------------------------------------------------

TEST(ContactBarrier, ZeroBeyondDhatInfiniteAtContact) {
  const Vec3 t0(0, 0, 0), t1(1, 0, 0), t2(0, 1, 0);
  const double dhat = 0.5;
  Vector12d g;
  Matrix12d h;
  EXPECT_EQ(pair_barrier(PairKind::PointTriangle, pts({0.2, 0.2, 0.5}, t0, t1, t2), dhat, &g, &h), 0);
  EXPECT_EQ(pair_barrier(PairKind::PointTriangle, pts({0.2, 0.2, 0.5000001}, t0, t1, t2), dhat, &g, &h), 0);
  EXPECT_TRUE(g.isZero(0));
  EXPECT_TRUE(h.isZero(0));
  EXPECT_GT(pair_barrier(PairKind::PointTriangle, pts({0.2, 0.2, 0.4999}, t0, t1, t2), dhat), 0);
  EXPECT_EQ(pair_barrier(PairKind::PointTriangle, pts({0.2, 0.2, 0}, t0, t1, t2), dhat),
            std::numeric_limits<double>::infinity());
  // Touching parallel edges: infinite although the mollifier vanishes there.
  EXPECT_EQ(pair_barrier(PairKind::EdgeEdge, pts({0, 0, 0}, {1, 0, 0}, {0.5, 0, 0}, {2, 0, 0}), dhat),
            std::numeric_limits<double>::infinity());
  // b is C2 at dhat: b, b', b'' all vanish as s -> s_hat, and b decreases towards it.
  const BarrierValue near = barrier(0.25 * (1 - 1e-6), 0.25);
  EXPECT_GT(near.b, 0);
  EXPECT_LT(near.db, 0);
  EXPECT_NEAR(near.b, 0, 1e-15);
  EXPECT_NEAR(near.d2b, 0, 1e-4);
}

TEST(ContactBarrier, GradientAndHessianMatchFiniteDifferences) {
  std::vector<Case> cases = feature_cases();
  // Mollified edge pairs: nearly parallel (sin^2 ~ 1e-4 < 1e-3) crossing and side by side.
  cases.push_back({"mollified crossing", PairKind::EdgeEdge,
                   pts({-0.5, 0, 0}, {0.5, 0.005, 0}, {-0.5, 0.003, 0.2}, {0.5, -0.004, 0.21}), ClosestFeatures::EdgeEdge});
  cases.push_back({"mollified side by side", PairKind::EdgeEdge,
                   pts({0, 0, 0}, {1, 0.004, 0}, {0.3, 0.1, 0.2}, {1.3, 0.1, 0.21}), ClosestFeatures::PointEdge});
  const double dhat = 1.5;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    Vector12d g;
    Matrix12d h;
    const double e = pair_barrier(c.kind, c.x, dhat, &g, &h);
    ASSERT_GT(e, 0);
    const double step = 1e-6;
    const double scale = std::max(1e-3, g.cwiseAbs().maxCoeff());
    for (int i = 0; i < 12; ++i) {
      const PairPoints xp = perturbed(c.x, i, step), xm = perturbed(c.x, i, -step);
      const double fd = (pair_barrier(c.kind, xp, dhat) - pair_barrier(c.kind, xm, dhat)) / (2 * step);
      EXPECT_NEAR(g[i], fd, 1e-6 * scale) << "coordinate " << i;
      Vector12d gp, gm;
      pair_barrier(c.kind, xp, dhat, &gp);
      pair_barrier(c.kind, xm, dhat, &gm);
      const Vector12d gd = (gp - gm) / (2 * step);
      const double tol = 1e-5 * std::max(1.0, h.cwiseAbs().maxCoeff());
      for (int j = 0; j < 12; ++j) EXPECT_NEAR(h(j, i), gd[j], tol) << "entry " << j << ", " << i;
    }
  }
}

TEST(ContactBarrier, GaussNewtonHessianIsPsdAndExactAlongTheApproach) {
  // A point over a triangle's interior approaching along the normal: the distance is linear in
  // that motion, so the Gauss-Newton Hessian's curvature there is the barrier's exact one.
  const double dhat = 0.5;
  for (double height : {0.4, 0.1, 0.01}) {
    SCOPED_TRACE(height);
    const PairPoints x = pts({0.2, 0.3, height}, {0, 0, 0}, {1, 0, 0}, {0, 1, 0});
    const Matrix12d h = pair_barrier_gauss_newton(PairKind::PointTriangle, x, dhat);
    Matrix12d exact;
    pair_barrier(PairKind::PointTriangle, x, dhat, nullptr, &exact);
    EXPECT_NEAR(h(2, 2), exact(2, 2), 1e-9 * std::abs(exact(2, 2)));
    EXPECT_GT(h(2, 2), 0);
    const Eigen::SelfAdjointEigenSolver<Matrix12d> eig(h);
    EXPECT_GT(eig.eigenvalues().minCoeff(), -1e-12 * eig.eigenvalues().cwiseAbs().maxCoeff());
  }
  // Every kind of closest feature: positive semi-definite, rank one, zero beyond dhat.
  for (const Case& c : feature_cases()) {
    SCOPED_TRACE(c.name);
    const Matrix12d h = pair_barrier_gauss_newton(c.kind, c.x, 1.5);
    const Eigen::SelfAdjointEigenSolver<Matrix12d> eig(h);
    const double top = eig.eigenvalues().maxCoeff();
    EXPECT_GT(top, 0);
    EXPECT_GT(eig.eigenvalues().minCoeff(), -1e-12 * top);
    EXPECT_LT(eig.eigenvalues()[10], 1e-12 * top);
    EXPECT_TRUE(pair_barrier_gauss_newton(c.kind, c.x, 1e-3).isZero(0));
  }
}

TEST(ContactBarrier, ProjectionIsPositiveSemidefiniteAndKeepsPositiveParts) {
  std::mt19937 rng(3);
  for (int i = 0; i < 20; ++i) {
    Matrix12d a = Matrix12d::Random();
    a = (a + a.transpose()).eval();
    Matrix12d p = a;
    project_to_psd(p);
    Eigen::SelfAdjointEigenSolver<Matrix12d> ea(a), ep(p);
    EXPECT_GE(ep.eigenvalues().minCoeff(), -1e-12);
    // The positive eigenvalues survive unchanged.
    std::vector<double> pos, kept;
    for (int k = 0; k < 12; ++k) {
      if (ea.eigenvalues()[k] > 1e-9) pos.push_back(ea.eigenvalues()[k]);
      if (ep.eigenvalues()[k] > 1e-9) kept.push_back(ep.eigenvalues()[k]);
    }
    ASSERT_EQ(pos.size(), kept.size());
    for (std::size_t k = 0; k < pos.size(); ++k) EXPECT_NEAR(pos[k], kept[k], 1e-10);
  }
}

// ---- CCD of single pairs -------------------------------------------------------------------

namespace {

struct Motion {
  const char* name;
  PairKind kind;
  PairPoints x, dx;
  double contact; // first time the pair touches (> 1: never within the step)
};

// First time in [0, t_end] the pair's distance falls to `floor`, by dense sampling then bisection
// (the distance is Lipschitz, and these motions approach monotonically near the crossing).
double first_time_at(const Motion& m, double floor, double t_end) {
  const int n = 20000;
  double prev = 0;
  for (int i = 1; i <= n; ++i) {
    const double t = t_end * i / n;
    if (std::sqrt(pair_distance(m.kind, moved(m.x, m.dx, t)).squared) <= floor) {
      double lo = prev, hi = t;
      for (int k = 0; k < 60; ++k) {
        const double mid = (lo + hi) / 2;
        (std::sqrt(pair_distance(m.kind, moved(m.x, m.dx, mid)).squared) <= floor ? hi : lo) = mid;
      }
      return lo;
    }
    prev = t;
  }
  return std::numeric_limits<double>::infinity();
}

std::vector<Motion> contact_motions() {
  const Vec3 t0(0, 0, 0), t1(1, 0, 0), t2(0, 1, 0), zero(0, 0, 0);
  return {
      // A point falls onto the face at speed 2 from height 1: contact at t = 0.5.
      {"point onto face", PairKind::PointTriangle, pts({0.2, 0.2, 1}, t0, t1, t2), pts({0, 0, -2}, zero, zero, zero), 0.5},
      // The triangle rises to meet a resting point: contact at t = 0.25.
      {"face onto point", PairKind::PointTriangle, pts({0.3, 0.3, 1}, t0, t1, t2), pts(zero, {0, 0, 4}, {0, 0, 4}, {0, 0, 4}),
       0.25},
      // A point slides obliquely onto the edge y = 0 from beside it (contact at t = 0.8).
      {"point onto edge", PairKind::PointTriangle, pts({0.1, -0.8, 0}, t0, t1, t2), pts({0.5, 1, 0}, zero, zero, zero), 0.8},
      // A point runs into a corner along the diagonal: contact at 1 (the end of the step).
      {"point onto corner at the end", PairKind::PointTriangle, pts({2, -1, 0}, t0, t1, t2),
       pts({-1, 1, 0}, zero, zero, zero), 1.0},
      // Grazing: the point's path touches the corner (1, 0, 0) tangentially at t = 0.5 and leaves.
      {"grazing a corner", PairKind::PointTriangle, pts({0.5, -0.5, 0}, t0, t1, t2), pts({1, 1, 0}, zero, zero, zero), 0.5},
      // Grazing a face: the point skims the plane at height 0 over the interior at t = 0.5.
      {"skimming the face", PairKind::PointTriangle, pts({-0.4, 0.2, 0.1}, t0, t1, t2),
       pts({1.2, 0, -0.2}, zero, zero, zero), 0.5},
      // Perpendicular edges: the upper one drops by 1.5 in a unit step from height 0.6 (t = 0.4).
      {"crossing edges", PairKind::EdgeEdge, pts({-1, 0, 0}, {1, 0, 0}, {0, -1, 0.6}, {0, 1, 0.6}),
       pts(zero, zero, {0, 0, -1.5}, {0, 0, -1.5}), 0.4},
      // Both edges move, towards each other, and rotate: they meet at t = 0.5 (checked by sampling).
      {"rotating edges", PairKind::EdgeEdge, pts({-1, 0, -0.5}, {1, 0, -0.5}, {0.2, -1, 0.5}, {-0.2, 1, 0.5}),
       pts({0, 0, 1}, {0, 0, 1}, {-0.2, 0.4, -1}, {0.2, -0.4, -1}), 0.5},
      // Parallel edges side by side closing a gap of 0.3 at speed 1: t = 0.3.
      {"parallel edges closing", PairKind::EdgeEdge, pts({0, 0, 0}, {1, 0, 0}, {0.4, 0.3, 0}, {1.4, 0.3, 0}),
       pts(zero, zero, {0, -1, 0}, {0, -1, 0}), 0.3},
      // Collinear edges end to end: gap 0.5 closed at speed 1 (t = 0.5).
      {"collinear edges", PairKind::EdgeEdge, pts({0, 0, 0}, {1, 0, 0}, {1.5, 0, 0}, {2.5, 0, 0}),
       pts(zero, zero, {-1, 0, 0}, {-1, 0, 0}), 0.5},
  };
}

} // namespace

TEST(PairCcd, StopsBeforeContactAndNotMuchEarlier) {
  const double keep = 0.1;
  for (const Motion& m : contact_motions()) {
    SCOPED_TRACE(m.name);
    // Sanity of the hand-built contact time.
    EXPECT_LT(std::sqrt(pair_distance(m.kind, moved(m.x, m.dx, m.contact)).squared), 1e-9);
    const double d0 = std::sqrt(pair_distance(m.kind, m.x).squared);
    const double floor = keep * d0;
    const double t = pair_step_bound(m.kind, m.x, m.dx, 1.0, {keep});
    EXPECT_LT(t, m.contact);
    // Never below the floor on [0, t] (dense check)...
    for (int i = 0; i <= 2000; ++i)
      ASSERT_GE(std::sqrt(pair_distance(m.kind, moved(m.x, m.dx, t * i / 2000)).squared), floor * (1 - 1e-9)) << i;
    // ...and not absurdly early: at least 90 % of the time at which the floor is reached
    // (head-on motions reach exactly it).
    const double t_floor = first_time_at(m, floor, m.contact);
    EXPECT_LE(t, t_floor * (1 + 1e-9));
    EXPECT_GE(t, 0.9 * t_floor) << "floor reached at " << t_floor;
  }
}

TEST(PairCcd, HeadOnMotionsStopAtTheKeptFraction) {
  const Vec3 t0(0, 0, 0), t1(1, 0, 0), t2(0, 1, 0), zero(0, 0, 0);
  for (double keep : {0.05, 0.1, 0.5}) {
    const double t = pair_step_bound(PairKind::PointTriangle, pts({0.2, 0.2, 1}, t0, t1, t2),
                                     pts({0, 0, -2}, zero, zero, zero), 1.0, {keep});
    EXPECT_NEAR(t, (1 - keep) * 0.5, 1e-12) << keep;
  }
}

TEST(PairCcd, MotionsThatNeverTouchGetTheFullStep) {
  const Vec3 t0(0, 0, 0), t1(1, 0, 0), t2(0, 1, 0), zero(0, 0, 0);
  // Moving away; sliding parallel above the face; parallel edges sliding along each other;
  // a rigid translation of the whole pair.
  EXPECT_EQ(pair_step_bound(PairKind::PointTriangle, pts({0.2, 0.2, 0.1}, t0, t1, t2), pts({0, 0, 1}, zero, zero, zero), 1.0), 1.0);
  EXPECT_EQ(pair_step_bound(PairKind::PointTriangle, pts({0.1, 0.1, 0.1}, t0, t1, t2), pts({0.3, 0.3, 0}, zero, zero, zero), 1.0), 1.0);
  EXPECT_EQ(pair_step_bound(PairKind::EdgeEdge, pts({0, 0, 0}, {1, 0, 0}, {0, 0.2, 0}, {1, 0.2, 0}),
                            pts(zero, zero, {3, 0, 0}, {3, 0, 0}), 1.0), 1.0);
  const Vec3 v(5, -3, 2);
  EXPECT_EQ(pair_step_bound(PairKind::PointTriangle, pts({0.2, 0.2, 1e-9}, t0, t1, t2), pts(v, v, v, v), 1.0), 1.0);
  // Contact only after the step: the step is free.
  EXPECT_EQ(pair_step_bound(PairKind::PointTriangle, pts({0.2, 0.2, 1}, t0, t1, t2), pts({0, 0, -0.5}, zero, zero, zero), 1.0), 1.0);
}

TEST(PairCcd, TouchingPairsThatMoveGetZero) {
  const Vec3 t0(0, 0, 0), t1(1, 0, 0), t2(0, 1, 0), zero(0, 0, 0);
  EXPECT_EQ(pair_step_bound(PairKind::PointTriangle, pts({0.2, 0.2, 0}, t0, t1, t2), pts({0, 0, 1}, zero, zero, zero), 1.0), 0);
  EXPECT_EQ(pair_step_bound(PairKind::EdgeEdge, pts({-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}),
                            pts(zero, zero, {0, 0, 1}, {0, 0, 1}), 1.0), 0);
}

TEST(PairCcd, PairsTouchingToRoundingAreThoseItCannotMove) {
  const Vec3 t0(0, 0, 0), t1(1, 0, 0), t2(0, 1, 0), zero(0, 0, 0), up(0, 0, 1e-3);
  for (double gap : {0.0, 1e-14, 1e-11, 1e-9, 1e-6}) {
    SCOPED_TRACE("gap " + std::to_string(gap));
    const PairPoints x = pts({0.2, 0.2, gap}, t0, t1, t2);
    const bool touching = pair_touches_to_rounding(PairKind::PointTriangle, x);
    // Within ten allowances (about 7e-7 at this size and place): touching to rounding ...
    EXPECT_EQ(touching, gap < 1e-8);
    // ... and then a slow relative motion is certified for next to nothing; otherwise for much of it.
    const double bound = pair_step_bound(PairKind::PointTriangle, x, pts(-up, zero, zero, zero), 1.0);
    if (touching) EXPECT_LT(bound, 1e-4);
    else EXPECT_GT(bound, 0.5 * 0.9 * gap / 1e-3);
  }
  // Far from the origin the allowance grows with the coordinates.
  const Vec3 far(1e6, 1e6, 1e6);
  EXPECT_TRUE(pair_touches_to_rounding(PairKind::PointTriangle, pts(far + Vec3(0.2, 0.2, 1e-9), far + t0, far + t1, far + t2)));
  EXPECT_TRUE(pair_touches_to_rounding(PairKind::EdgeEdge, pts({-1, 0, 0}, {1, 0, 0}, {0, -1, 1e-12}, {0, 1, 1e-12})));
  EXPECT_FALSE(pair_touches_to_rounding(PairKind::EdgeEdge, pts({-1, 0, 0}, {1, 0, 0}, {0, -1, 1e-3}, {0, 1, 1e-3})));
}

TEST(PairCcd, RandomMotionsNeverPassBelowTheFloor) {
  std::mt19937 rng(11);
  const double keep = 0.1;
  for (int i = 0; i < 300; ++i) {
    for (PairKind kind : {PairKind::PointTriangle, PairKind::EdgeEdge}) {
      const PairPoints x = random_points(rng), dx = random_points(rng, 2);
      const double t = pair_step_bound(kind, x, dx, 1.0, {keep});
      const double floor = keep * std::sqrt(pair_distance(kind, x).squared);
      for (int s = 0; s <= 400; ++s)
        ASSERT_GE(std::sqrt(pair_distance(kind, moved(x, dx, t * s / 400)).squared), floor * (1 - 1e-9)) << i;
    }
  }
}

// ---- the guard on shells -------------------------------------------------------------------

namespace {

struct ShellCase {
  ShellBoundary boundary;
  int n = 0;                 // base vertices (shell vertices: 2n)
  Eigen::MatrixXd X;         // 2n x 3
  std::vector<char> movable; // the top
};

ShellCase make_shell(const test::SimpleMesh& base, double eta) {
  ShellCase s;
  s.n = static_cast<int>(base.V.rows());
  s.boundary = shell_boundary(base.F, s.n);
  s.X.resize(2 * s.n, 3);
  s.X << base.V, offset_top(base.V, base.F, eta);
  s.movable.assign(2 * s.n, 0);
  std::fill(s.movable.begin() + s.n, s.movable.end(), 1);
  return s;
}

// Every pair of the module's rules closer than `radius` at X, by brute force, as sorted keys
// independent of the guard's numbering: (kind, sorted vertex ids of each primitive).
std::set<std::vector<int>> brute_force_pairs(const ShellCase& s, const Eigen::MatrixXd& X, double radius,
                                             const std::vector<char>& excluded = {}) {
  const Eigen::MatrixXi& F = s.boundary.F;
  const int m = static_cast<int>(F.rows());
  auto is_excluded = [&](int t) { return !excluded.empty() && excluded[t]; };
  std::set<int> excluded_vertices;
  std::set<std::pair<int, int>> edges, excluded_edges;
  for (int t = 0; t < m; ++t)
    for (int k = 0; k < 3; ++k) {
      const std::pair<int, int> e = std::minmax(F(t, k), F(t, (k + 1) % 3));
      edges.insert(e);
      if (is_excluded(t)) {
        excluded_vertices.insert(F(t, k));
        excluded_edges.insert(e);
      }
    }
  std::set<int> vertices(F.data(), F.data() + F.size());
  auto point = [&](int v) -> Vec3 { return X.row(v).transpose(); };
  std::set<std::vector<int>> out;
  for (int v : vertices)
    for (int t = 0; t < m; ++t) {
      if (v == F(t, 0) || v == F(t, 1) || v == F(t, 2) || is_excluded(t) || excluded_vertices.count(v)) continue;
      if (!s.movable[v] && !s.movable[F(t, 0)] && !s.movable[F(t, 1)] && !s.movable[F(t, 2)]) continue;
      if (point_triangle_distance(pts(point(v), point(F(t, 0)), point(F(t, 1)), point(F(t, 2)))).squared <
          radius * radius) {
        std::vector<int> key = {0, v, F(t, 0), F(t, 1), F(t, 2)};
        std::sort(key.begin() + 2, key.end());
        out.insert(key);
      }
    }
  for (auto a = edges.begin(); a != edges.end(); ++a)
    for (auto b = std::next(a); b != edges.end(); ++b) {
      if (a->first == b->first || a->first == b->second || a->second == b->first || a->second == b->second) continue;
      if (excluded_edges.count(*a) || excluded_edges.count(*b)) continue;
      if (!s.movable[a->first] && !s.movable[a->second] && !s.movable[b->first] && !s.movable[b->second]) continue;
      if (edge_edge_distance(pts(point(a->first), point(a->second), point(b->first), point(b->second))).squared <
          radius * radius)
        out.insert({1, a->first, a->second, b->first, b->second});
    }
  return out;
}

std::set<std::vector<int>> keys(const std::vector<ContactPair>& pairs) {
  std::set<std::vector<int>> out;
  for (const ContactPair& p : pairs) {
    const auto& v = p.vertices;
    if (p.kind == PairKind::PointTriangle) {
      std::vector<int> key = {0, v[0], v[1], v[2], v[3]};
      std::sort(key.begin() + 2, key.end());
      out.insert(key);
    } else {
      std::pair<int, int> a = std::minmax(v[0], v[1]), b = std::minmax(v[2], v[3]);
      if (b < a) std::swap(a, b);
      out.insert({1, a.first, a.second, b.first, b.second});
    }
  }
  return out;
}

// A brute-force key's kind and points at X.
PairKind key_kind(const std::vector<int>& key) { return key[0] == 0 ? PairKind::PointTriangle : PairKind::EdgeEdge; }
PairPoints key_points(const std::vector<int>& key, const Eigen::MatrixXd& X) {
  PairPoints p;
  for (int i = 0; i < 4; ++i) p[i] = X.row(key[1 + i]).transpose();
  return p;
}

// Brute-force barrier over the pairs closer than dhat.
double brute_force_energy(const ShellCase& s, const Eigen::MatrixXd& X, double dhat) {
  double e = 0;
  for (const std::vector<int>& k : brute_force_pairs(s, X, dhat)) e += pair_barrier(key_kind(k), key_points(k, X), dhat);
  return e;
}

Eigen::MatrixXd jitter(const Eigen::MatrixXd& X, double amount, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-amount, amount);
  Eigen::MatrixXd Y = X;
  for (Eigen::Index i = 0; i < Y.size(); ++i) Y.data()[i] += u(rng);
  return Y;
}

} // namespace

TEST(ContactGuard, CandidateListEqualsBruteForceAndIsKeptForSmallMoves) {
  for (const auto& [name, base] : std::vector<std::pair<std::string, test::SimpleMesh>>{
           {"plane", test::plane(6, 0.3)}, {"sphere", test::icosphere(1)}}) {
    SCOPED_TRACE(name);
    ShellCase s = make_shell(base, 0.15);
    // Crumple the shell: many pairs at all distances, fixed base vertices moved too.
    const Eigen::MatrixXd X0 = jitter(s.X, 0.08, 1);
    ContactOptions o;
    o.dhat = 0.12;
    o.slack = 0.06;
    ContactGuard guard(s.boundary, 2 * s.n, s.movable, o);
    const double e0 = guard.energy(X0);
    EXPECT_EQ(guard.candidate_builds(), 1);
    const auto expected = brute_force_pairs(s, X0, o.dhat + o.slack);
    EXPECT_GT(expected.size(), 50u);
    EXPECT_EQ(keys(guard.candidate_pairs()), expected);
    EXPECT_NEAR(e0, brute_force_energy(s, X0, o.dhat), 1e-12 * std::max(1.0, e0));
    EXPECT_GT(guard.active_pairs(), 0);

    // A move of every vertex by less than slack / 2: the list stays, energies stay exact.
    Eigen::MatrixXd X1 = X0;
    X1.array() += (jitter(Eigen::MatrixXd::Zero(X0.rows(), 3), 1, 2).rowwise().normalized() * 0.029).array();
    const double e1 = guard.energy(X1);
    EXPECT_EQ(guard.candidate_builds(), 1);
    EXPECT_NEAR(e1, brute_force_energy(s, X1, o.dhat), 1e-12 * std::max(1.0, e1));
    const auto list = keys(guard.candidate_pairs());
    for (const auto& k : brute_force_pairs(s, X1, o.dhat)) EXPECT_TRUE(list.count(k));

    // A larger move: rebuilt at the new positions.
    const Eigen::MatrixXd X2 = jitter(X0, 0.05, 3);
    guard.energy(X2);
    EXPECT_EQ(guard.candidate_builds(), 2);
    EXPECT_EQ(keys(guard.candidate_pairs()), brute_force_pairs(s, X2, o.dhat + o.slack));
  }
}

TEST(ContactGuard, FarFromTheOriginTheCandidateListIsStillTheBruteForceOne) {
  // Scans in survey coordinates sit millions of units from zero, where a float steps by 0.25-0.5:
  // the broad phase's float boxes are measured from the shell, and the list stays exact.
  ShellCase s = make_shell(test::icosphere(1), 0.15);
  const Eigen::MatrixXd X0 = jitter(s.X, 0.08, 1);
  ContactOptions o;
  o.dhat = 0.12;
  o.slack = 0.06;
  for (const Eigen::RowVector3d& offset : {Eigen::RowVector3d(5e5, 4e6, 120), Eigen::RowVector3d(-2e7, 0, 3e5)}) {
    SCOPED_TRACE(offset);
    const Eigen::MatrixXd X = X0.rowwise() + offset;
    ContactGuard guard(s.boundary, 2 * s.n, s.movable, o);
    const double e = guard.energy(X);
    EXPECT_EQ(keys(guard.candidate_pairs()), brute_force_pairs(s, X, o.dhat + o.slack));
    EXPECT_NEAR(e, brute_force_energy(s, X, o.dhat), 1e-9 * std::max(1.0, e));
  }
}

TEST(ContactGuard, CandidateListOfAPartlyMovableTopFollowsItsMoves) {
  // Only the top over x > 0 moves (a solver repairing a region): the fixed part's search structure
  // is kept across rebuilds while it stays, and remade when a fixed vertex moves.
  ShellCase s = make_shell(test::plane(8, 0.3), 0.3); // thicker than dhat + slack
  for (int i = s.n; i < 2 * s.n; ++i) s.movable[i] = s.X(i, 0) > 0;
  const Eigen::MatrixXd X0 = jitter(s.X, 0.05, 21);
  ContactOptions o;
  o.dhat = 0.1;
  o.slack = 0.04;
  ContactGuard guard(s.boundary, 2 * s.n, s.movable, o);
  guard.energy(X0);
  EXPECT_EQ(keys(guard.candidate_pairs()), brute_force_pairs(s, X0, o.dhat + o.slack));
  Eigen::MatrixXd X1 = X0;
  const Eigen::MatrixXd noise = jitter(Eigen::MatrixXd::Zero(2 * s.n, 3), 0.08, 22);
  for (int i = 0; i < 2 * s.n; ++i)
    if (s.movable[i]) X1.row(i) += noise.row(i);
  guard.energy(X1);
  EXPECT_EQ(guard.candidate_builds(), 2);
  EXPECT_EQ(keys(guard.candidate_pairs()), brute_force_pairs(s, X1, o.dhat + o.slack));
  // A base vertex under the moving top rises within reach of it: new pairs with fixed vertices.
  Eigen::MatrixXd X2 = X1;
  int lifted = 0;
  while (!(s.X(lifted, 0) > 0.4 && std::abs(s.X(lifted, 1)) < 0.5)) ++lifted;
  X2(lifted, 2) += 0.3;
  guard.energy(X2);
  EXPECT_EQ(guard.candidate_builds(), 3);
  const auto expected = brute_force_pairs(s, X2, o.dhat + o.slack);
  EXPECT_TRUE(std::any_of(expected.begin(), expected.end(), [&](const std::vector<int>& k) {
    return std::find(k.begin() + 1, k.end(), lifted) != k.end();
  }));
  EXPECT_EQ(keys(guard.candidate_pairs()), expected);
}

TEST(ContactGuard, ASmallRegionTravellingAcrossALargeShellMeetsEveryPair) {
  // A solver repairing one small spot of a large shell: the fixed triangles' search structure
  // holds only those within reach of the spot, and is made again as the spot travels out of that
  // reach, also for one long swept step; the candidate lists and the pairs cutting the step are
  // those of brute force over the whole shell all the same.
  ShellCase s = make_shell(test::plane(12, 0.2), 0.15);
  int spot = 0;
  for (int i = s.n; i < 2 * s.n; ++i) {
    s.movable[i] = (s.X.row(i).head<2>() - Eigen::RowVector2d(-0.6, -0.6)).norm() < 0.2;
    spot += s.movable[i];
  }
  ASSERT_GE(spot, 3);
  ContactOptions o;
  o.dhat = 0.04;
  o.slack = 0.04;
  ContactGuard guard(s.boundary, 2 * s.n, s.movable, o);
  Eigen::MatrixXd X = s.X;
  for (int step = 0; step < 8; ++step) {
    SCOPED_TRACE(step);
    guard.energy(X);
    EXPECT_EQ(keys(guard.candidate_pairs()), brute_force_pairs(s, X, o.dhat + o.slack));
    for (int i = 0; i < 2 * s.n; ++i)
      if (s.movable[i]) X.row(i) += Eigen::RowVector3d(0.13, 0.1, step % 2 ? -0.05 : 0.03);
  }
  EXPECT_GE(guard.fixed_patch_builds(), 2);

  // From the start, one long step across the sheet, through the wavy top and the base.
  ContactGuard fresh(s.boundary, 2 * s.n, s.movable, o);
  X = s.X;
  fresh.energy(X);
  ASSERT_EQ(fresh.fixed_patch_builds(), 1);
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(2 * s.n, 3);
  for (int i = 0; i < 2 * s.n; ++i)
    if (s.movable[i]) D.row(i) << 1.3, 1.1, 0.0;
  std::vector<ContactPair> cutting;
  fresh.step_bound(X, D, 1.0, &cutting);
  EXPECT_EQ(fresh.fixed_patch_builds(), 2);
  const PairCcdOptions ccd{o.keep_fraction, o.dhat};
  std::set<std::vector<int>> expected;
  for (const std::vector<int>& k : brute_force_pairs(s, X, 1e9)) {
    PairPoints x, dx;
    for (int i = 0; i < 4; ++i) {
      x[i] = X.row(k[1 + i]).transpose();
      dx[i] = D.row(k[1 + i]).transpose();
    }
    if (pair_step_bound(k[0] == 0 ? PairKind::PointTriangle : PairKind::EdgeEdge, x, dx, 1.0, ccd) < 1.0)
      expected.insert(k);
  }
  EXPECT_FALSE(expected.empty());
  EXPECT_EQ(keys(cutting), expected);
}

TEST(ContactGuard, OtherOptionsActAsAGuardMadeWithThem) {
  // A solver weakening its barrier keeps its guard and sets a smaller dhat: every answer is then
  // the one a guard made with those options gives, bit for bit, at the positions it had and at new ones.
  ShellCase s = make_shell(test::plane(10, 0.3), 0.1);
  for (int i = s.n; i < 2 * s.n; ++i) s.movable[i] = s.X(i, 0) < -0.5; // few movable: the fixed patch is cut
  const Eigen::MatrixXd X0 = jitter(s.X, 0.03, 31), X1 = jitter(s.X, 0.03, 32);
  ContactOptions strong, weak;
  strong.dhat = 0.08;
  weak.dhat = 0.03;
  weak.keep_fraction = 0.2;
  ContactGuard guard(s.boundary, 2 * s.n, s.movable, strong);
  guard.energy(X0);
  ContactGuard made(s.boundary, 2 * s.n, s.movable, weak);
  guard.set_options(weak);
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(2 * s.n, 3);
  for (int i = 0; i < 2 * s.n; ++i)
    if (s.movable[i]) D.row(i) << 0.6, 0.1, -0.15;
  for (const Eigen::MatrixXd* X : {&X0, &X1}) {
    EXPECT_EQ(guard.energy(*X), made.energy(*X));
    EXPECT_EQ(keys(guard.candidate_pairs()), keys(made.candidate_pairs()));
    EXPECT_EQ(guard.min_distance(*X), made.min_distance(*X));
    EXPECT_EQ(guard.step_bound(*X, D), made.step_bound(*X, D));
    Eigen::MatrixXd g = Eigen::MatrixXd::Zero(2 * s.n, 3), h = g;
    guard.add_gradient(*X, 1.0, g);
    made.add_gradient(*X, 1.0, h);
    EXPECT_EQ(g, h);
  }
  ContactOptions bad = weak;
  bad.dhat = -1;
  EXPECT_THROW(guard.set_options(bad), InputError);
}

TEST(ContactGuard, SkipsFixedOnlyPairsAndExcludedTriangles) {
  // A base folded so tightly that base triangles come close to each other, and a jittered top.
  test::SimpleMesh base = test::plane(6, 0);
  for (Eigen::Index i = 0; i < base.V.rows(); ++i) {
    const double x = base.V(i, 0);
    base.V(i, 0) = 0.05 * x; // squeezed: a narrow strip folded onto itself in x
    base.V(i, 2) = std::abs(x);
  }
  ShellCase s = make_shell(base, 0.05);
  const Eigen::MatrixXd X = jitter(s.X, 0.02, 5);
  std::vector<char> excluded(s.boundary.size(), 0);
  for (int t = 0; t < s.boundary.size(); t += 7) excluded[t] = 1;
  ContactOptions o;
  o.dhat = 0.1;
  ContactGuard guard(s.boundary, 2 * s.n, s.movable, o, excluded);
  guard.energy(X);
  const auto list = guard.candidate_pairs();
  EXPECT_EQ(keys(list), brute_force_pairs(s, X, o.dhat + o.dhat, excluded));
  std::set<int> excluded_vertices;
  for (int t = 0; t < s.boundary.size(); ++t)
    if (excluded[t])
      for (int k = 0; k < 3; ++k) excluded_vertices.insert(s.boundary.F(t, k));
  for (const ContactPair& p : list) {
    EXPECT_TRUE(std::any_of(p.vertices.begin(), p.vertices.end(), [&](int v) { return v >= s.n; }));
    if (p.kind == PairKind::PointTriangle) EXPECT_FALSE(excluded_vertices.count(p.vertices[0]));
  }
  // Without the rules the base against itself would be there: the test has such pairs.
  ShellCase all = s;
  all.movable.assign(2 * s.n, 1);
  const auto unfiltered = brute_force_pairs(all, X, 2 * o.dhat);
  EXPECT_TRUE(std::any_of(unfiltered.begin(), unfiltered.end(), [&](const std::vector<int>& k) {
    return std::all_of(k.begin() + 1, k.end(), [&](int v) { return v < s.n; });
  }));
}

TEST(ContactGuard, GradientAndHessianOfTheSumMatchFiniteDifferences) {
  ShellCase s = make_shell(test::plane(4, 0.3), 0.1);
  const Eigen::MatrixXd X = jitter(s.X, 0.05, 9);
  ContactOptions o;
  o.dhat = 0.15;
  ContactGuard guard(s.boundary, 2 * s.n, s.movable, o);
  const double e = guard.energy(X);
  ASSERT_GT(guard.active_pairs(), 5);
  ASSERT_TRUE(std::isfinite(e));
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(2 * s.n, 3);
  guard.add_gradient(X, 2.0, G);
  const double step = 1e-7;
  for (int v = 0; v < 2 * s.n; v += 3)
    for (int a = 0; a < 3; ++a) {
      Eigen::MatrixXd Xp = X, Xm = X;
      Xp(v, a) += step;
      Xm(v, a) -= step;
      const double fd = 2.0 * (guard.energy(Xp) - guard.energy(Xm)) / (2 * step);
      EXPECT_NEAR(G(v, a), fd, 1e-5 * std::max(1e-6, G.cwiseAbs().maxCoeff())) << v << " " << a;
    }
  std::vector<Eigen::Triplet<double>> triplets;
  guard.add_hessian(X, 1.0, triplets);
  Eigen::SparseMatrix<double> H(6 * s.n, 6 * s.n);
  H.setFromTriplets(triplets.begin(), triplets.end());
  const Eigen::MatrixXd dense(H);
  EXPECT_NEAR((dense - dense.transpose()).norm(), 0, 1e-12 * dense.norm());
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(dense).eigenvalues().minCoeff(), -1e-9 * dense.norm());
  std::set<std::pair<int, int>> entries; // one triplet per entry: the pairs' terms come summed
  for (const auto& t : triplets) EXPECT_TRUE(entries.insert({t.row(), t.col()}).second) << t.row() << " " << t.col();

  // Only the blocks between kept vertices (a solver's free ones), in the same order, either form.
  std::vector<char> kept(2 * s.n, 1);
  for (int v = 0; v < 2 * s.n; v += 2) kept[v] = 0;
  for (bool projected : {true, false}) {
    std::vector<Eigen::Triplet<double>> all, some;
    guard.add_hessian(X, 1.0, all, projected);
    guard.add_hessian(X, 1.0, some, projected, &kept);
    EXPECT_LT(some.size(), all.size());
    EXPECT_TRUE(test::same_triplets(some, test::kept_blocks(all, kept))) << "projected " << projected;
  }
  const std::vector<char> short_flags(s.n, 1);
  std::vector<Eigen::Triplet<double>> unused;
  EXPECT_THROW(guard.add_hessian(X, 1.0, unused, true, &short_flags), InputError);
}

TEST(ContactGuard, StepOfAFlatShellIntoItsBaseStopsAtTheKeptFraction) {
  // Top 0.2 above a flat base (farther than dhat + slack: off the candidate list) moved down by
  // 0.4 in a unit step, or the fixed base moved up by 0.4: the gap closes at s = 0.5 and its floor
  // is keep * dhat.
  ShellCase s = make_shell(test::plane(6, 0), 0.2);
  ContactOptions o;
  o.dhat = 0.05;
  o.keep_fraction = 0.1;
  const double expected = (0.2 - o.keep_fraction * o.dhat) / 0.4;
  for (bool move_base : {false, true}) {
    SCOPED_TRACE(move_base ? "base moves" : "top moves");
    ContactGuard guard(s.boundary, 2 * s.n, s.movable, o);
    Eigen::MatrixXd D = Eigen::MatrixXd::Zero(2 * s.n, 3);
    D.col(2).segment(move_base ? 0 : s.n, s.n).setConstant(move_base ? 0.4 : -0.4);
    // The top/base pairs approach head-on and stop exactly there; the side walls collapse with
    // them, and their pairs approach a little slower than the speed bound, so they stop within the
    // advancement's tolerance before it.
    const double alpha = guard.step_bound(s.X, D, 1.0);
    EXPECT_LE(alpha, expected + 1e-12);
    EXPECT_GE(alpha, expected * (1 - 1e-4));
    EXPECT_EQ(guard.step_bound(s.X, D, 0.3), 0.3);
    EXPECT_EQ(guard.energy(s.X), 0);
  }
}

TEST(ContactGuard, ShellsSteppedAlongCollidingMotionsNeverIntersect) {
  // A sheet folded into a tight V whose top grows far into the fold, and a sphere shell whose top
  // is pushed through its base on one side: each step is clamped by step_bound; the boundary
  // surface stays free of intersections by exact tests, and the motion gets close to contact.
  test::SimpleMesh fold = test::plane(8, 0);
  for (Eigen::Index i = 0; i < fold.V.rows(); ++i) fold.V(i, 2) = 1.5 * std::abs(fold.V(i, 0));
  ShellCase v_shell = make_shell(fold, 0.02);
  Eigen::MatrixXd v_target = v_shell.X;
  v_target.bottomRows(v_shell.n) = offset_top(fold.V, fold.F, 0.8);

  ShellCase ball = make_shell(test::icosphere(2), 0.1);
  Eigen::MatrixXd ball_target = ball.X;
  for (int i = ball.n; i < 2 * ball.n; ++i)
    if (ball.X(i, 0) > 0) ball_target(i, 0) -= 1.5; // the right half of the top through the base

  for (auto [name, s, target] : {std::tuple{"fold", &v_shell, &v_target}, std::tuple{"sphere", &ball, &ball_target}}) {
    SCOPED_TRACE(name);
    ContactOptions o;
    o.dhat = 0.02;
    ContactGuard guard(s->boundary, 2 * s->n, s->movable, o);
    Eigen::MatrixXd X = s->X;
    ASSERT_TRUE(self_intersecting_pairs(X, s->boundary.F).empty());
    ASSERT_FALSE(self_intersecting_pairs(*target, s->boundary.F).empty()); // the motion does collide
    const double start = guard.min_distance(X);
    for (int it = 0; it < 40; ++it) {
      const Eigen::MatrixXd D = *target - X;
      const double alpha = guard.step_bound(X, D, 1.0);
      ASSERT_GE(alpha, 0);
      ASSERT_LT(alpha, 1);
      X += alpha * D;
      ASSERT_TRUE(self_intersecting_pairs(X, s->boundary.F).empty()) << "step " << it;
      ASSERT_TRUE(std::isfinite(guard.energy(X)));
    }
    EXPECT_LT(guard.min_distance(X), 0.1 * std::min(start, o.dhat));
    EXPECT_GT(guard.candidate_builds(), 1);
  }
}

TEST(ContactGuard, TreesRefitThroughARollGiveTheListsAndBoundsOfFreshOnes) {
  // A guard keeps its trees' shapes from the first positions and refits them: a sheet rolled up
  // step by step until its ends come round towards each other must still get the candidate lists
  // of brute force and, for each next step, the bound and cutting pairs of a guard made afresh
  // there. Once with every vertex movable, once with the base fixed but moved by the caller.
  ShellCase s = make_shell(test::plane(10, 0), 0.08);
  auto rolled = [&](double curvature) { // about an axis along y, the top on the inside
    Eigen::MatrixXd X = s.X;
    if (curvature == 0) return X;
    for (int i = 0; i < 2 * s.n; ++i) {
      const double phi = curvature * s.X(i, 0), r = 1 / curvature - s.X(i, 2);
      X(i, 0) = std::sin(phi) * r;
      X(i, 2) = 1 / curvature - std::cos(phi) * r;
    }
    return X;
  };
  for (bool base_movable : {true, false}) {
    SCOPED_TRACE(base_movable ? "all movable" : "base fixed");
    std::vector<char> movable = s.movable;
    if (base_movable) movable.assign(2 * s.n, 1);
    ShellCase c = s;
    c.movable = movable;
    ContactOptions o;
    o.dhat = 0.05;
    o.slack = 0.04;
    ContactGuard guard(s.boundary, 2 * s.n, movable, o);
    for (int k = 0; k < 7; ++k) {
      SCOPED_TRACE(k);
      const Eigen::MatrixXd X = rolled(0.45 * k), next = rolled(0.45 * (k + 1));
      guard.energy(X);
      EXPECT_EQ(guard.candidate_builds(), k + 1);
      EXPECT_EQ(keys(guard.candidate_pairs()), brute_force_pairs(c, X, o.dhat + o.slack));
      ContactGuard fresh(s.boundary, 2 * s.n, movable, o);
      std::vector<ContactPair> cutting, fresh_cutting;
      EXPECT_EQ(guard.step_bound(X, next - X, 1.0, &cutting), fresh.step_bound(X, next - X, 1.0, &fresh_cutting));
      EXPECT_EQ(cutting, fresh_cutting);
      if (k == 6) EXPECT_FALSE(cutting.empty()); // the ends meet in the last step
    }
  }
}

TEST(ContactGuard, PairsCuttingAStepAreThoseWhoseOwnBoundIsBelowIt) {
  // The guarded solver holds the vertices of every pair that would cut a step of tau: the list is
  // every pair of the module's rules (brute force over all of them) whose own CCD bound over
  // [0, tau] is below tau, and the bound returned with it is the plain one.
  test::SimpleMesh fold = test::plane(6, 0);
  for (Eigen::Index i = 0; i < fold.V.rows(); ++i) fold.V(i, 2) = 1.5 * std::abs(fold.V(i, 0));
  ShellCase s = make_shell(fold, 0.02);
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(2 * s.n, 3);
  D.bottomRows(s.n) = offset_top(fold.V, fold.F, 0.8) - s.X.bottomRows(s.n);
  ContactOptions o;
  o.dhat = 0.02;
  ContactGuard guard(s.boundary, 2 * s.n, s.movable, o);
  const PairCcdOptions ccd{o.keep_fraction, o.dhat};
  const std::set<std::vector<int>> all = brute_force_pairs(s, s.X, 1e9);
  const double plain = guard.step_bound(s.X, D, 1.0);
  ASSERT_LT(plain, 0.5);
  for (double tau : {1.0, 0.5, 2 * plain, plain}) {
    SCOPED_TRACE(tau);
    std::vector<ContactPair> cutting;
    EXPECT_EQ(guard.step_bound(s.X, D, tau, &cutting), guard.step_bound(s.X, D, tau));
    std::set<std::vector<int>> expected;
    for (const std::vector<int>& k : all) {
      PairPoints x, dx;
      for (int i = 0; i < 4; ++i) {
        x[i] = s.X.row(k[1 + i]).transpose();
        dx[i] = D.row(k[1 + i]).transpose();
      }
      if (pair_step_bound(k[0] == 0 ? PairKind::PointTriangle : PairKind::EdgeEdge, x, dx, tau, ccd) < tau)
        expected.insert(k);
    }
    EXPECT_EQ(keys(cutting), expected);
    EXPECT_EQ(cutting.size(), expected.size()); // no pair twice
    EXPECT_EQ(expected.empty(), tau <= plain);

    // Limited to the pairs of one vertex (as the solver asks again after holding a few): those of
    // the list with that vertex, on whichever side of a leaf pair its triangles are.
    std::vector<char> touching(2 * s.n, 0);
    if (!expected.empty()) touching[expected.begin()->back()] = 1;
    std::set<std::vector<int>> expected_touching;
    for (const std::vector<int>& k : expected)
      if (touching[k[1]] || touching[k[2]] || touching[k[3]] || touching[k[4]]) expected_touching.insert(k);
    EXPECT_EQ(expected_touching.empty(), expected.empty());
    if (tau >= 0.5) EXPECT_LT(expected_touching.size(), expected.size());
    std::vector<ContactPair> cutting_touching;
    guard.step_bound(s.X, D, tau, &cutting_touching, &touching);
    EXPECT_EQ(keys(cutting_touching), expected_touching);
    EXPECT_EQ(cutting_touching.size(), expected_touching.size());

    // As flags: the moving vertices of those pairs, added to those the caller set (which spare
    // the pairs they cover their CCD, not the others' vertices).
    auto moving_vertices = [&](const std::set<std::vector<int>>& pairs, std::vector<char> flags) {
      for (const std::vector<int>& k : pairs)
        for (int i = 1; i <= 4; ++i)
          if (!D.row(k[i]).isZero(0)) flags[k[i]] = 1;
      return flags;
    };
    const std::vector<char> none(2 * s.n, 0);
    std::vector<char> held = none;
    guard.flag_cutting_vertices(s.X, D, tau, held);
    EXPECT_EQ(held, moving_vertices(expected, none));
    held = none;
    guard.flag_cutting_vertices(s.X, D, tau, held, &touching);
    EXPECT_EQ(held, moving_vertices(expected_touching, none));
    // Set beforehand: one moving vertex of every pair but the last, and a vertex no pair moves.
    std::vector<char> prior = none;
    for (auto k = expected.begin(); k != expected.end() && std::next(k) != expected.end(); ++k)
      for (int i = 4; i >= 1; --i)
        if (!D.row((*k)[i]).isZero(0)) {
          prior[(*k)[i]] = 1;
          break;
        }
    prior[0] = 1;
    held = prior;
    guard.flag_cutting_vertices(s.X, D, tau, held);
    EXPECT_EQ(held, moving_vertices(expected, prior));
  }
}

TEST(ContactGuard, RandomWildMotionsNeverIntersect) {
  // Thin shells shaken by random smooth displacement fields much larger than the thickness (base
  // vertices moved too, as a prescribed base motion): every clamped step stays clean by exact tests.
  std::mt19937 rng(5);
  std::normal_distribution<double> normal(0, 1);
  for (const auto& [name, base] : std::vector<std::pair<std::string, test::SimpleMesh>>{
           {"sphere", test::icosphere(1)}, {"wavy plane", test::plane(5, 0.4)}}) {
    SCOPED_TRACE(name);
    ShellCase s = make_shell(base, 0.08);
    s.movable.assign(2 * s.n, 1);
    ContactOptions o;
    o.dhat = 0.03;
    ContactGuard guard(s.boundary, 2 * s.n, s.movable, o);
    Eigen::MatrixXd X = s.X;
    for (int motion = 0; motion < 6; ++motion) {
      // Sum of a few random plane waves per axis: neighbours move alike, far parts apart.
      Eigen::MatrixXd D = Eigen::MatrixXd::Zero(2 * s.n, 3);
      for (int wave = 0; wave < 3; ++wave) {
        const Eigen::Vector3d k(normal(rng), normal(rng), normal(rng)), a(normal(rng), normal(rng), normal(rng));
        const double phase = normal(rng);
        for (int v = 0; v < 2 * s.n; ++v) D.row(v) += 0.3 * std::sin(3 * k.dot(X.row(v)) + phase) * a.transpose();
      }
      for (int step = 0; step < 4; ++step) {
        const double alpha = guard.step_bound(X, D, 1.0);
        X += alpha * D;
        ASSERT_TRUE(self_intersecting_pairs(X, s.boundary.F).empty()) << "motion " << motion << " step " << step;
        ASSERT_TRUE(std::isfinite(guard.energy(X)));
        D *= 1 - alpha; // the rest of the motion
      }
    }
  }
}

TEST(ContactGuard, BadInputThrows) {
  ShellCase s = make_shell(test::plane(2, 0), 0.1);
  ContactOptions o;
  o.dhat = 0.1;
  EXPECT_THROW(ContactGuard(s.boundary, 2 * s.n, std::vector<char>(3, 1), o), InputError);
  EXPECT_THROW(ContactGuard(s.boundary, 2 * s.n, s.movable, o, std::vector<char>(2, 0)), InputError);
  EXPECT_THROW(ContactGuard(s.boundary, s.n, std::vector<char>(s.n, 1), o), InputError);
  ContactOptions bad = o;
  bad.dhat = 0;
  EXPECT_THROW(ContactGuard(s.boundary, 2 * s.n, s.movable, bad), InputError);
  bad = o;
  bad.keep_fraction = 1;
  EXPECT_THROW(ContactGuard(s.boundary, 2 * s.n, s.movable, bad), InputError);
  ContactGuard guard(s.boundary, 2 * s.n, s.movable, o);
  EXPECT_THROW(guard.energy(s.X.topRows(3)), InputError);
  Eigen::MatrixXd X = s.X;
  X(4, 1) = std::nan("");
  EXPECT_THROW(guard.energy(X), InputError);
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(2 * s.n, 3);
  D(2, 0) = std::numeric_limits<double>::infinity();
  EXPECT_THROW(guard.step_bound(s.X, D), InputError);
  const std::vector<char> short_flags(s.n, 1);
  EXPECT_THROW(guard.step_bound(s.X, Eigen::MatrixXd::Zero(2 * s.n, 3), 1.0, nullptr, &short_flags), InputError);
  std::vector<char> short_held(s.n, 0);
  EXPECT_THROW(guard.flag_cutting_vertices(s.X, Eigen::MatrixXd::Zero(2 * s.n, 3), 1.0, short_held), InputError);
}

TEST(ContactGuard, CappedSupportsAreQuietAtTheirRestAndWeightedBeyondIt) {
  // A rest state whose top lies closer to its base than dhat: uncapped, the barrier pushes there.
  const ShellCase s = make_shell(test::plane(6, 0.3), 0.1);
  ContactOptions o;
  o.dhat = 0.15;
  const double fraction = 0.5;
  ContactGuard plain(s.boundary, 2 * s.n, s.movable, o), capped(s.boundary, 2 * s.n, s.movable, o);
  ASSERT_GT(plain.energy(s.X), 0);
  capped.cap_support(s.X, fraction);
  EXPECT_EQ(capped.energy(s.X), 0.0);
  EXPECT_EQ(capped.active_pairs(), 0);
  Eigen::MatrixXd g = Eigen::MatrixXd::Zero(2 * s.n, 3);
  capped.add_gradient(s.X, 1.0, g);
  EXPECT_EQ(g.norm(), 0.0);

  // The caps again, by brute force: fraction x the distance at rest of each vertex's closest pair
  // within the candidate radius (dhat + slack = 2 dhat).
  std::vector<double> cap(2 * s.n, std::numeric_limits<double>::infinity());
  for (const std::vector<int>& key : brute_force_pairs(s, s.X, 2 * o.dhat)) {
    const double d = std::sqrt(pair_squared_distance(key_kind(key), key_points(key, s.X)));
    for (int i = 1; i <= 4; ++i) cap[key[i]] = std::min(cap[key[i]], fraction * d);
  }
  // Pressed: the top at a third of its height, jittered. Each pair's barrier has its own support
  // (its vertices' smallest cap) and the weight (dhat / support)^3.
  Eigen::MatrixXd Y = s.X;
  for (int i = 0; i < s.n; ++i) Y.row(s.n + i) = s.X.row(i) + (s.X.row(s.n + i) - s.X.row(i)) / 3;
  Y.bottomRows(s.n) = jitter(Y.bottomRows(s.n), 0.005, 41);
  double expected = 0;
  for (const std::vector<int>& key : brute_force_pairs(s, Y, o.dhat)) {
    double support = o.dhat;
    for (int i = 1; i <= 4; ++i) support = std::min(support, std::max(cap[key[i]], 1e-2 * o.dhat));
    expected += std::pow(o.dhat / support, 3) * pair_barrier(key_kind(key), key_points(key, Y), support);
  }
  ASSERT_GT(expected, 0);
  const double energy = capped.energy(Y);
  EXPECT_NEAR(energy, expected, 1e-12 * expected);
  EXPECT_GT(std::abs(energy - plain.energy(Y)), 1e-6 * expected); // the caps change it
  // Its gradient against central differences, on top coordinates where the barrier acts.
  g.setZero();
  capped.add_gradient(Y, 1.0, g);
  int checked = 0;
  for (int v = s.n; v < 2 * s.n && checked < 12; ++v)
    for (int a = 0; a < 3 && g.row(v).norm() > 1e-3 * g.norm(); ++a, ++checked) {
      const double h = 1e-7;
      Eigen::MatrixXd P = Y, M = Y;
      P(v, a) += h;
      M(v, a) -= h;
      const double fd = (capped.energy(P) - capped.energy(M)) / (2 * h);
      EXPECT_NEAR(g(v, a), fd, 1e-5 * g.row(v).norm()) << "vertex " << v << " axis " << a;
    }
  EXPECT_GT(checked, 0);
  EXPECT_THROW(capped.cap_support(s.X, 0), InputError);
  EXPECT_THROW(capped.cap_support(s.X, 1.5), InputError);
}
