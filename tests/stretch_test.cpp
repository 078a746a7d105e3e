// Stretch of known maps (docs/design.md "Quality measures").
#include <gshell/error.h>
#include <gshell/quality/stretch.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/shell/prism_tets.h>

#include "core_test_meshes.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

using namespace gshell;

namespace {

struct ShellCase {
  RestTets rest;
  Eigen::MatrixXd X; // the rest positions themselves (a seamless shell)
};

ShellCase sphere_shell() {
  const auto m = test::icosphere(2);
  const int n = static_cast<int>(m.V.rows());
  ShellCase s;
  s.X.resize(2 * n, 3);
  s.X << m.V, 1.05 * m.V;
  s.rest = rest_tets_from_positions(s.X, build_prism_tets(m.F, n));
  return s;
}

} // namespace

TEST(Stretch, PositionsThatDoNotFitTheTetsAreInputErrors) {
  const ShellCase s = sphere_shell();
  EXPECT_THROW(tet_stretch(s.rest, s.X.topRows(s.X.rows() / 2)), InputError); // the top is missing
  EXPECT_THROW(tet_deformation_determinants(s.rest, Eigen::MatrixXd::Zero(s.X.rows(), 2)), InputError);
  EXPECT_THROW(stretch_stats(s.rest, Eigen::MatrixXd(0, 3)), InputError);
  EXPECT_THROW(stretch_stats(Eigen::VectorXd::Zero(3), Eigen::VectorXd::Zero(2), Eigen::VectorXd::Ones(3)), InputError);
  EXPECT_THROW(rest_tets_from_positions(s.X, s.rest.T.leftCols(3)), InputError);
  EXPECT_THROW(rest_tets_from_positions(s.X.leftCols(2), s.rest.T), InputError);
}

TEST(Stretch, IdentityIsZero) {
  const ShellCase s = sphere_shell();
  const Eigen::VectorXd st = tet_stretch(s.rest, s.X);
  EXPECT_LT(st.cwiseAbs().maxCoeff(), 1e-20);
  const StretchStats stats = stretch_stats(s.rest, s.X);
  EXPECT_EQ(stats.inverted, 0);
  EXPECT_LT(stats.max, 1e-20);
  EXPECT_TRUE((tet_deformation_determinants(s.rest, s.X).array() - 1).abs().maxCoeff() < 1e-9);
}

TEST(Stretch, UniformScaleGivesThreeSquaredExcess) {
  const ShellCase s = sphere_shell();
  for (double scale : {0.5, 0.9, 1.3, 2.0}) {
    const Eigen::MatrixXd Y = scale * s.X + Eigen::MatrixXd::Constant(s.X.rows(), 3, 0.25);
    const Eigen::VectorXd st = tet_stretch(s.rest, Y);
    const double expected = 3 * (scale - 1) * (scale - 1);
    EXPECT_LT((st.array() - expected).abs().maxCoeff(), 1e-9) << scale;
    const StretchStats stats = stretch_stats(s.rest, Y);
    EXPECT_NEAR(stats.mean, expected, 1e-9);
    EXPECT_NEAR(stats.volume_mean, expected, 1e-9);
    EXPECT_NEAR(stats.max, expected, 1e-9);
    EXPECT_NEAR(stats.p99, expected, 1e-9);
    EXPECT_EQ(stats.inverted, 0);
  }
}

TEST(Stretch, RotationIsZero) {
  const ShellCase s = sphere_shell();
  const Eigen::Matrix3d R = Eigen::AngleAxisd(1.1, Eigen::Vector3d(1, 2, -0.5).normalized()).toRotationMatrix();
  const Eigen::MatrixXd Y = (s.X * R.transpose()).rowwise() + Eigen::RowVector3d(1, -2, 3);
  EXPECT_LT(tet_stretch(s.rest, Y).maxCoeff(), 1e-18);
}

TEST(Stretch, MirrorCountsInvertedTets) {
  const ShellCase s = sphere_shell();
  Eigen::MatrixXd Y = s.X;
  Y.col(0) *= -1; // a reflection: every tet inverted, stretch = (1+1)^2 on the flipped axis
  const StretchStats stats = stretch_stats(s.rest, Y);
  EXPECT_EQ(stats.inverted, s.rest.size());
  EXPECT_NEAR(stats.max, 4.0, 1e-9);
}

TEST(Stretch, PercentileAndVolumeWeighting) {
  // Two tets, one stretched, with different rest volumes: the weighted mean follows the volumes.
  Eigen::MatrixXd X(5, 3);
  X << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 3;
  Eigen::MatrixXi T(2, 4);
  T << 0, 1, 2, 3, 0, 1, 2, 4;
  const RestTets rest = rest_tets_from_positions(X, T);
  Eigen::MatrixXd Y = X;
  Y.row(3) << 0, 0, 2; // tet 0 stretched by 2 along z: stretch 1
  const StretchStats stats = stretch_stats(rest, Y);
  EXPECT_NEAR(stats.mean, 0.5, 1e-12);
  EXPECT_NEAR(stats.volume_mean, 1.0 / 4.0, 1e-12); // volumes 1/6 and 3/6
  EXPECT_NEAR(stats.max, 1.0, 1e-12);
  EXPECT_NEAR(stats.p99, 1.0, 1e-12);
}
