// Embedded detail: (tet, barycentric) storage in a rest shell, carried by deformed shells.
#include <gshell/deform/embedding.h>
#include <gshell/deform/tet_locator.h>
#include <gshell/geometry/closest_point.h>
#include <gshell/error.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/shell/shell.h>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include "shell_fixtures.h"

#include <random>

namespace gshell {
namespace {

using test::flat_plane_shell;
using test::sphere_shell;

/// Random points given by barycentric coordinates of random tets (strictly inside).
Eigen::MatrixXd barycentric_points(const Eigen::MatrixXd& X, const Eigen::MatrixXi& T, int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pick(0, static_cast<int>(T.rows()) - 1);
  std::uniform_real_distribution<double> w(0.05, 1.0);
  Eigen::MatrixXd P(count, 3);
  for (int p = 0; p < count; ++p) {
    const int t = pick(rng);
    Eigen::Vector4d l(w(rng), w(rng), w(rng), w(rng));
    l /= l.sum();
    P.row(p).setZero();
    for (int k = 0; k < 4; ++k) P.row(p) += l(k) * X.row(T(t, k));
  }
  return P;
}

Eigen::MatrixXd rigidly_moved(const Eigen::MatrixXd& X, const Eigen::Matrix3d& R, const Eigen::RowVector3d& t) {
  return (X * R.transpose()).rowwise() + t;
}

Eigen::Matrix3d some_rotation() {
  return Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
}

TEST(Embedding, BarycentricPointsAreReproducedAtRest) {
  for (const Shell& shell : {flat_plane_shell(8, 0.1), sphere_shell(2, 0.15)}) {
    const Eigen::MatrixXd X = shell.vertices();
    const Eigen::MatrixXi T = build_prism_tets(shell.F, shell.num_base_vertices());
    const Eigen::MatrixXd P = barycentric_points(X, T, 2000, 7);
    const Embedding e = embed_points(X, T, P);
    EXPECT_TRUE(e.outside.empty());
    EXPECT_EQ(e.size(), P.rows());
    EXPECT_LT((carry(e, X) - P).cwiseAbs().maxCoeff(), 1e-12);
    for (int p = 0; p < e.size(); ++p) {
      EXPECT_GE(e.bary.row(p).minCoeff(), -TetLocator::kInsideTolerance);
      EXPECT_NEAR(e.bary.row(p).sum(), 1.0, 1e-12);
      for (int k = 0; k < 4; ++k) EXPECT_EQ(e.vertices(p, k), T(e.tet(p), k));
    }
  }
}

TEST(Embedding, FollowsRigidMotionExactly) {
  const Shell shell = sphere_shell(2, 0.2);
  const Eigen::MatrixXd X = shell.vertices();
  const Eigen::MatrixXi T = build_prism_tets(shell.F, shell.num_base_vertices());
  const Eigen::MatrixXd P = barycentric_points(X, T, 1000, 11);
  const Embedding e = embed_points(X, T, P);
  const Eigen::Matrix3d R = some_rotation();
  const Eigen::RowVector3d t(2.0, -1.0, 0.5);
  EXPECT_LT((carry(e, rigidly_moved(X, R, t)) - rigidly_moved(P, R, t)).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(Embedding, MeshVerticesAndFacePointsCountAsInside) {
  // Points on the shell's boundary surfaces and on faces shared by tets are inside.
  const Shell shell = flat_plane_shell(6, 0.1);
  const Eigen::MatrixXd X = shell.vertices();
  const Eigen::MatrixXi T = build_prism_tets(shell.F, shell.num_base_vertices());
  const Embedding e = embed_points(X, T, X);
  EXPECT_TRUE(e.outside.empty());
  EXPECT_LT((carry(e, X) - X).cwiseAbs().maxCoeff(), 1e-13);
}

TEST(Embedding, OutsidePointsAreReportedBoundToTheNearestTetAndExtrapolated) {
  const double eta = 0.1;
  const Shell shell = flat_plane_shell(8, eta);
  const Eigen::MatrixXd X = shell.vertices();
  const Eigen::MatrixXi T = build_prism_tets(shell.F, shell.num_base_vertices());
  Eigen::MatrixXd P(5, 3);
  P << 0.1, 0.2, 0.05,   // inside
      0.3, -0.4, 0.35,   // 0.25 above the top
      -0.5, 0.5, -0.2,   // 0.2 below the base
      1.5, 0.0, 0.05,    // 0.5 beyond the side x = 1
      0.0, 0.0, 0.1;     // on the top surface: inside
  const Embedding e = embed_points(X, T, P);
  ASSERT_EQ(e.outside.size(), 3u);
  EXPECT_EQ(e.outside[0], 1);
  EXPECT_EQ(e.outside[1], 2);
  EXPECT_EQ(e.outside[2], 3);
  EXPECT_NEAR(e.max_outside_distance, 0.5, 1e-12);
  // The nearest tet really is nearest: the point above the top is bound to a tet touching the
  // top right under it.
  const Eigen::MatrixXd at_rest = carry(e, X);
  EXPECT_LT((at_rest - P).cwiseAbs().maxCoeff(), 1e-12); // extrapolation keeps the rest pose
  // Under a rigid motion, outside points move rigidly too (one affine map per tet).
  const Eigen::Matrix3d R = some_rotation();
  const Eigen::RowVector3d t(0.1, 0.2, 0.3);
  EXPECT_LT((carry(e, rigidly_moved(X, R, t)) - rigidly_moved(P, R, t)).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(Embedding, NearestTetOfAnOutsidePointIsTheClosestOne) {
  const Shell shell = sphere_shell(1, 0.2);
  const Eigen::MatrixXd X = shell.vertices();
  const Eigen::MatrixXi T = build_prism_tets(shell.F, shell.num_base_vertices());
  const TetLocator locator(X, T);
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int k = 0; k < 200; ++k) {
    Eigen::Vector3d p(g(rng), g(rng), g(rng));
    // Beyond the shell (radius <= ~1.2), or in the hollow inside it (radius >= ~0.95).
    p = p.normalized() * (k % 2 ? 1.6 + 0.5 * std::abs(g(rng)) : 0.9 * std::abs(std::tanh(g(rng))));
    const TetHit hit = locator.locate(p);
    ASSERT_FALSE(hit.inside);
    const auto distance_to_tet = [&](int t) {
      static constexpr int faces[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
      double d = std::numeric_limits<double>::infinity();
      for (const auto& f : faces)
        d = std::min(d, (closest_point_on_triangle(p, X.row(T(t, f[0])), X.row(T(t, f[1])), X.row(T(t, f[2]))) - p).norm());
      return d;
    };
    double brute = std::numeric_limits<double>::infinity();
    for (int t = 0; t < T.rows(); ++t) brute = std::min(brute, distance_to_tet(t));
    EXPECT_NEAR(hit.distance, brute, 1e-12);
    EXPECT_NEAR(distance_to_tet(hit.tet), brute, 1e-12); // the tet it is bound to is a nearest one
  }
}

TEST(Embedding, RejectsNonFinitePoints) {
  const Shell shell = flat_plane_shell(2, 0.1);
  Eigen::MatrixXd P(1, 3);
  P << 0, std::nan(""), 0;
  EXPECT_THROW(embed_points(shell.vertices(), build_prism_tets(shell.F, 9), P), InputError);
}

// Tet ids index the caller's X: a T from a bigger mesh, or an X from a smaller one, must be
// refused rather than read out of bounds.
TEST(Embedding, TetIdsOutsideTheVerticesAreInputErrors) {
  const Shell shell = flat_plane_shell(2, 0.1);
  const Eigen::MatrixXd X = shell.vertices();
  const Eigen::MatrixXi T = build_prism_tets(shell.F, 9);
  EXPECT_THROW(TetLocator(X.topRows(X.rows() - 1), T), InputError);
  EXPECT_THROW(TetLocator(X.leftCols(2), T), InputError);
  EXPECT_THROW(TetLocator(X, T.leftCols(3)), InputError);
  const Embedding e = embed_points(X, T, X.topRows(3));
  EXPECT_THROW(carry(e, X.topRows(1)), InputError);
  EXPECT_NEAR((carry(e, X) - X.topRows(3)).norm(), 0, 1e-12);
}

} // namespace
} // namespace gshell
