// smoothed_vertex_normals: the start direction of generation, vertex normals diffused over a radius.
#include <gshell/error.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/shell/smoothed_normals.h>

#include "shell_fixtures.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

using namespace gshell;

namespace {

double angle(const Eigen::RowVector3d& a, const Eigen::RowVector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

} // namespace

TEST(SmoothedNormals, RadiusZeroIsTheVertexNormalsBitForBit) {
  TriMesh m = make_sphere(2);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  for (int i = 0; i < m.V.rows(); ++i) m.V.row(i) *= 1 + u(rng);
  NormalSmoothing stats;
  EXPECT_EQ(smoothed_vertex_normals(m.V, m.F, 0, &stats), vertex_normals(m.V, m.F));
  EXPECT_EQ(stats.iterations, 0);
}

TEST(SmoothedNormals, SphereNormalsStayRadial) {
  // On a sphere the smoothed field of radial normals is radial; the discretisation (edge weights
  // are exact only on equilateral faces, the icosphere's are not) may tilt it by about a degree
  // at a radius of two edges.
  const TriMesh m = make_sphere(4);
  const Eigen::MatrixXd N0 = vertex_normals(m.V, m.F);
  const Eigen::MatrixXd N = smoothed_vertex_normals(m.V, m.F, 0.15);
  double worst0 = 0, worst = 0;
  for (int i = 0; i < m.V.rows(); ++i) {
    const Eigen::RowVector3d radial = m.V.row(i).normalized();
    worst0 = std::max(worst0, angle(N0.row(i), radial));
    worst = std::max(worst, angle(N.row(i), radial));
    EXPECT_NEAR(N.row(i).norm(), 1.0, 1e-12);
  }
  EXPECT_LT(worst0, 1e-2);
  EXPECT_LT(worst, 2e-2);
}

TEST(SmoothedNormals, AFoldIsAveragedOverAboutTheRadiusOnly) {
  const int res = 80;      // edge 0.025 along x
  const double r = 0.1;    // in model units; the half-planes are about 1 wide
  const TriMesh m = test::folded_plane(res, 90);
  const Eigen::MatrixXd N = smoothed_vertex_normals(m.V, m.F, r);
  // Tilt of each vertex's smoothed normal from its own half-plane's normal, by distance to the fold.
  const double s = std::sin(M_PI / 4), c = std::cos(M_PI / 4);
  auto tilt_at = [&](double d_lo, double d_hi) {
    double lo = 1e9, hi = 0;
    for (int i = 0; i < m.V.rows(); ++i) {
      const double d = std::abs(m.V(i, 0)) / s; // distance along the half-plane to the fold
      if (d < d_lo || d > d_hi || std::abs(m.V(i, 1)) > 0.5) continue; // away from the open sides
      const Eigen::RowVector3d own = m.V(i, 0) > 0 ? Eigen::RowVector3d(-c, 0, s) : Eigen::RowVector3d(c, 0, s);
      const double a = angle(N.row(i), own) * 180 / M_PI;
      lo = std::min(lo, a);
      hi = std::max(hi, a);
    }
    return std::make_pair(lo, hi);
  };
  // On the fold: the bisector (+z), by symmetry.
  for (int i = 0; i < m.V.rows(); ++i)
    if (std::abs(m.V(i, 0)) < 1e-12 && std::abs(m.V(i, 1)) < 0.5)
      EXPECT_LT(angle(N.row(i), Eigen::RowVector3d(0, 0, 1)) * 180 / M_PI, 2.0) << i;
  const auto near = tilt_at(0.5 * r, 1.0 * r), mid = tilt_at(2 * r, 3 * r), far = tilt_at(6 * r, 10 * r);
  EXPECT_GT(near.first, 5.0);           // within the radius the two sides are averaged
  EXPECT_GT(near.first, mid.second);    // and less so further out
  EXPECT_LT(far.second, 1.0);           // beyond a few radii each side keeps its own normal
}

TEST(SmoothedNormals, IsolatedVerticesKeepAZeroNormal) {
  TriMesh m = make_plane(4);
  m.V.conservativeResize(m.V.rows() + 1, 3);
  m.V.row(m.V.rows() - 1) << 5, 5, 5;
  const Eigen::MatrixXd N = smoothed_vertex_normals(m.V, m.F, 0.2);
  EXPECT_EQ(N.row(m.V.rows() - 1).norm(), 0.0);
  for (int i = 0; i + 1 < m.V.rows(); ++i) EXPECT_NEAR(N(i, 2), 1.0, 1e-12) << i;
}

TEST(SmoothedNormals, BadRadiusIsAnInputError) {
  const TriMesh m = make_plane(4);
  for (double r : {-1.0, std::numeric_limits<double>::infinity(), std::numeric_limits<double>::quiet_NaN()})
    EXPECT_THROW(smoothed_vertex_normals(m.V, m.F, r), InputError) << r;
}
