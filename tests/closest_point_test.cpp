// Closest points on segments and triangles (geometry/closest_point.h): on the primitive, and no
// point of it is closer (checked against a dense sampling), also for flat triangles.
#include <gshell/geometry/closest_point.h>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>

using namespace gshell;

namespace {

// The nearest of (k+1)(k+2)/2 barycentric grid points of the triangle.
double sampled_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                        const Eigen::Vector3d& c, int k = 60) {
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= k; ++i)
    for (int j = 0; i + j <= k; ++j) {
      const double u = static_cast<double>(i) / k, v = static_cast<double>(j) / k;
      best = std::min(best, (a + u * (b - a) + v * (c - a) - p).norm());
    }
  return best;
}

// Barycentric coordinates of q in the plane of a non-degenerate triangle.
Eigen::Vector3d barycentric(const Eigen::Vector3d& q, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                            const Eigen::Vector3d& c) {
  const Eigen::Vector3d n = (b - a).cross(c - a);
  const double area2 = n.squaredNorm();
  return {(c - b).cross(q - b).dot(n) / area2, (a - c).cross(q - c).dot(n) / area2,
          (b - a).cross(q - a).dot(n) / area2};
}

} // namespace

TEST(ClosestPoint, OnTheTriangleAndNoSampleIsCloser) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  const auto random_point = [&] { return Eigen::Vector3d(u(rng), u(rng), u(rng)); };
  for (int trial = 0; trial < 300; ++trial) {
    const Eigen::Vector3d a = random_point(), b = random_point(), c = random_point();
    const Eigen::Vector3d p = 2 * random_point();
    ASSERT_FALSE(triangle_is_flat(a, b, c));
    const Eigen::Vector3d q = closest_point_on_triangle(p, a, b, c);
    const Eigen::Vector3d w = barycentric(q, a, b, c);
    EXPECT_NEAR(w.sum(), 1.0, 1e-9);
    EXPECT_GE(w.minCoeff(), -1e-9) << "trial " << trial;
    EXPECT_NEAR((q - a).dot((b - a).cross(c - a).normalized()), 0.0, 1e-12);
    // The grid's spacing bounds how much closer the true point may be than the nearest sample.
    EXPECT_LE((q - p).norm(), sampled_distance(p, a, b, c) + 1e-12) << "trial " << trial;
    EXPECT_TRUE(q == closest_point_on_triangle(p, a, b, c, false));
  }
}

TEST(ClosestPoint, RegionsOfARightTriangle) {
  const Eigen::Vector3d a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  EXPECT_TRUE(closest_point_on_triangle({0.2, 0.3, 5}, a, b, c).isApprox(Eigen::Vector3d(0.2, 0.3, 0)));
  EXPECT_TRUE(closest_point_on_triangle({-1, -1, 1}, a, b, c).isApprox(a));
  EXPECT_TRUE(closest_point_on_triangle({2, -1, 0}, a, b, c).isApprox(b));
  EXPECT_TRUE(closest_point_on_triangle({0.5, -2, 0}, a, b, c).isApprox(Eigen::Vector3d(0.5, 0, 0)));
  EXPECT_TRUE(closest_point_on_triangle({1, 1, 0}, a, b, c).isApprox(Eigen::Vector3d(0.5, 0.5, 0)));
}

TEST(ClosestPoint, FlatTrianglesAreTheirEdges) {
  const Eigen::Vector3d a(0, 0, 0), b(2, 0, 0), mid(1, 0, 0);
  EXPECT_TRUE(triangle_is_flat(a, b, mid));
  EXPECT_TRUE(triangle_is_flat(a, a, b));
  EXPECT_TRUE(triangle_is_flat(a, a, a));
  for (const Eigen::Vector3d p : {Eigen::Vector3d(0.5, 1, 0), Eigen::Vector3d(3, 1, -1), Eigen::Vector3d(-1, 0, 2)}) {
    const Eigen::Vector3d on_segment = closest_point_on_segment(p, a, b);
    EXPECT_TRUE(closest_point_on_triangle(p, a, b, mid).isApprox(on_segment));
    EXPECT_TRUE(closest_point_on_triangle(p, mid, a, b).isApprox(on_segment));
    EXPECT_TRUE(closest_point_on_triangle(p, a, a, b).isApprox(on_segment));
  }
  EXPECT_TRUE(closest_point_on_triangle({1, 1, 1}, a, a, a) == a);
  EXPECT_TRUE(closest_point_on_segment({5, 5, 5}, a, a) == a);
}
