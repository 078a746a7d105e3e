// Per-vertex thickness against analytic cases (offset plane, concentric spheres) and against an
// independent closest-point computation (CGAL's point-triangle distance) over all faces.
#include <gshell/error.h>
#include <gshell/quality/thickness.h>

#include "quality_test_meshes.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/squared_distance_3.h>
#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <random>

namespace gshell {
namespace {

TEST(Thickness, PlaneOffsetByHIsExactlyH) {
  const auto plane = test::grid_plane(16);
  const double h = 0.0375;
  Eigen::MatrixXd top = plane.V;
  top.col(2).array() += h;
  const Eigen::VectorXd t = vertex_thickness(plane.V, plane.F, top);
  ASSERT_EQ(t.size(), top.rows());
  for (Eigen::Index i = 0; i < t.size(); ++i) EXPECT_NEAR(t[i], h, 1e-15 * 16) << i;

  // Points over the interior of faces and edges (not over vertices), unpaired with the base.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> xy(-1, 1);
  Eigen::MatrixXd probes(200, 3);
  for (Eigen::Index i = 0; i < probes.rows(); ++i) probes.row(i) << xy(rng), xy(rng), -h;
  const Eigen::VectorXd tp = vertex_thickness(plane.V, plane.F, probes);
  for (Eigen::Index i = 0; i < tp.size(); ++i) EXPECT_NEAR(tp[i], h, 1e-15 * 16) << i;
}

// Distance of each face's plane from the centre of a sphere mesh centred at the origin.
double min_face_plane_distance(const TriMesh& m) {
  double d = std::numeric_limits<double>::infinity();
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    d = std::min(d, std::abs(n.dot(a)));
  }
  return d;
}

TEST(Thickness, ConcentricSpheres) {
  const double r = 2.0, h = 0.1;
  const auto base = test::icosphere(3, r);
  // Top vertex i radially over base vertex i: the base lies inside the sphere of radius r, so no
  // point of it is closer than h, and base vertex i is at exactly h.
  const Eigen::MatrixXd top = base.V * ((r + h) / r);
  const Eigen::VectorXd t = vertex_thickness(base.V, base.F, top);
  EXPECT_NEAR(t.minCoeff(), h, 1e-12);
  EXPECT_NEAR(t.maxCoeff(), h, 1e-12);

  // A differently faceted top sphere: its vertices sit over base facets, where the base dips
  // below radius r by at most r - (smallest face-plane distance) (the faceting error).
  const auto other = test::icosphere(4, r + h);
  const Eigen::MatrixXd rotated =
      other.V * Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::VectorXd tr = vertex_thickness(base.V, base.F, rotated);
  const double faceting = r - min_face_plane_distance(base);
  ASSERT_GT(faceting, 0.0);
  EXPECT_GE(tr.minCoeff(), h - 1e-12);
  EXPECT_LE(tr.maxCoeff(), h + faceting + 1e-12);
  EXPECT_GT(tr.mean(), h + 0.1 * faceting); // most top vertices do sit over facet interiors
}

// Closest distance from p to any face of (V, F), by CGAL, face by face; with `own` >= 0 (p is top
// vertex `own` of a shell) only over the faces at base vertex `own` and those p lies above.
double brute_force_distance(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::Vector3d& p,
                            int own = -1) {
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  const K::Point_3 q(p.x(), p.y(), p.z());
  double best = std::numeric_limits<double>::infinity();
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    if (own >= 0 && F(f, 0) != own && F(f, 1) != own && F(f, 2) != own) {
      const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
      if (!((b - a).cross(c - a).dot(p - a) > 0)) continue;
    }
    auto corner = [&](int k) { return K::Point_3(V(F(f, k), 0), V(F(f, k), 1), V(F(f, k), 2)); };
    best = std::min(best, CGAL::squared_distance(q, K::Triangle_3(corner(0), corner(1), corner(2))));
  }
  return std::sqrt(best);
}

TEST(Thickness, MatchesAllFacesClosestPoint) {
  const auto base = test::icosphere(2, 1.0, Eigen::Vector3d(0.2, -0.1, 0.3));
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> coord(-2, 2);
  Eigen::MatrixXd probes(300, 3);
  for (Eigen::Index i = 0; i < probes.rows(); ++i) probes.row(i) << coord(rng), coord(rng), coord(rng);
  const Eigen::VectorXd t = vertex_thickness(base.V, base.F, probes);
  for (Eigen::Index i = 0; i < probes.rows(); ++i)
    EXPECT_NEAR(t[i], brute_force_distance(base.V, base.F, probes.row(i).transpose()), 1e-12) << i;
}

TEST(Thickness, PairedShellMatchesAllFacesClosestPoint) {
  // A bumpy base and a top whose vertex i wanders around base vertex i: the pairing only
  // seeds the search, the answer must still be the closest point over the faces that count.
  TriMesh base = test::icosphere(3);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> bump(0.8, 1.2), jitter(-0.15, 0.15);
  for (Eigen::Index i = 0; i < base.V.rows(); ++i) base.V.row(i) *= bump(rng);
  Eigen::MatrixXd top = base.V;
  for (Eigen::Index i = 0; i < top.rows(); ++i)
    top.row(i) += Eigen::RowVector3d(jitter(rng), jitter(rng), jitter(rng)) + 0.1 * base.V.row(i);
  // An extra base vertex that no face uses is not part of the surface.
  base.V.conservativeResize(base.V.rows() + 1, 3);
  base.V.row(base.V.rows() - 1) << 5, 5, 5;
  top.conservativeResize(top.rows() + 1, 3);
  top.row(top.rows() - 1) << 5, 5, 5.001;

  const Eigen::VectorXd t = vertex_thickness(base.V, base.F, top);
  int nearer_behind = 0; // top vertices with a face nearer that they lie behind
  for (Eigen::Index i = 0; i + 1 < top.rows(); ++i) {
    const Eigen::Vector3d q = top.row(i).transpose();
    EXPECT_NEAR(t[i], brute_force_distance(base.V, base.F, q, static_cast<int>(i)), 1e-12) << i;
    nearer_behind += brute_force_distance(base.V, base.F, q) < t[i] - 1e-9;
  }
  EXPECT_GT(nearer_behind, 0); // the jitter puts some there, so the rule is exercised
  EXPECT_GT(t[top.rows() - 1], 5.0); // on no face: measured to every face
}

TEST(Thickness, ATopUnderTheBackOfAnotherPartIsMeasuredOnItsOwnSide) {
  // Two concentric spheres, both shells extruded outwards: the inner top (radius 1.04) passes
  // 0.01 under the outer base (1.05) but is 0.04 thick; the outer top is 0.05 thick.
  const auto inner = test::icosphere(3, 1.0), outer = test::icosphere(3, 1.05);
  const Eigen::Index n = inner.V.rows();
  TriMesh both;
  both.V.resize(2 * n, 3);
  both.V << inner.V, outer.V;
  both.F.resize(2 * inner.F.rows(), 3);
  both.F << inner.F, (outer.F.array() + static_cast<int>(n)).matrix();
  Eigen::MatrixXd top(2 * n, 3);
  top << inner.V * 1.04, outer.V * (1.10 / 1.05);
  const Eigen::VectorXd t = vertex_thickness(both.V, both.F, top);
  EXPECT_NEAR(t.head(n).minCoeff(), 0.04, 1e-12);
  EXPECT_NEAR(t.head(n).maxCoeff(), 0.04, 1e-12);
  EXPECT_NEAR(t.tail(n).minCoeff(), 0.05, 1e-12);
  EXPECT_NEAR(t.tail(n).maxCoeff(), 0.05, 1e-12);
  // Unpaired, the same points are measured to every face: 0.01 from the outer base at most.
  const Eigen::VectorXd any = vertex_thickness(both.V, both.F, Eigen::MatrixXd(top.topRows(n)));
  EXPECT_LE(any.maxCoeff(), 0.01 + 1e-12);
}

TEST(Thickness, JustAboveAFineBumpySurfaceMatchesAllFacesClosestPoint) {
  // Queries a small fraction of an edge above a curved surface: the search's oriented node boxes
  // (thin along the surface normal) prune nearly everything there, so a box that missed one of
  // its faces would show as a larger distance over that face. Probes over face interiors, edges
  // and vertices, some just below the surface.
  TriMesh base = test::icosphere(4);
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> bump(0.9, 1.1), unit(0, 1), height(-0.004, 0.004);
  for (Eigen::Index i = 0; i < base.V.rows(); ++i) base.V.row(i) *= bump(rng);
  Eigen::MatrixXd probes(3 * base.F.rows() / 4, 3);
  for (Eigen::Index k = 0; k < probes.rows(); ++k) {
    const Eigen::Index f = (4 * k) / 3;
    const Eigen::Vector3d a = base.V.row(base.F(f, 0)), b = base.V.row(base.F(f, 1)), c = base.V.row(base.F(f, 2));
    double u = unit(rng), v = unit(rng);
    if (k % 7 == 0) v = 0;        // on an edge
    if (k % 11 == 0) u = v = 0;   // at a vertex
    if (u + v > 1) u = 1 - u, v = 1 - v;
    const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    probes.row(k) = (a + u * (b - a) + v * (c - a) + height(rng) * n).transpose();
  }
  const Eigen::VectorXd t = vertex_thickness(base.V, base.F, probes);
  for (Eigen::Index k = 0; k < probes.rows(); ++k)
    EXPECT_NEAR(t[k], brute_force_distance(base.V, base.F, probes.row(k).transpose()), 1e-12) << k;
}

TEST(Thickness, DegenerateBaseFacesAreTheirSegments) {
  // One proper face far away and one face with collinear corners along the x axis.
  Eigen::MatrixXd base(6, 3);
  base << 10, 10, 10, 11, 10, 10, 10, 11, 10, 0, 0, 0, 2, 0, 0, 1, 0, 0;
  const Eigen::MatrixXi F = (Eigen::MatrixXi(2, 3) << 0, 1, 2, 3, 4, 5).finished();
  Eigen::MatrixXd probes(3, 3);
  probes << 1.5, 0.3, 0.4, -3, 0, 4, 2, 0, 0;
  const Eigen::VectorXd t = vertex_thickness(base, F, probes);
  EXPECT_NEAR(t[0], 0.5, 1e-14);
  EXPECT_NEAR(t[1], 5.0, 1e-14);
  EXPECT_NEAR(t[2], 0.0, 1e-14);
  // All corners equal: a point.
  const Eigen::MatrixXi dot = (Eigen::MatrixXi(1, 3) << 3, 3, 3).finished();
  EXPECT_NEAR(vertex_thickness(base, dot, probes)[1], 5.0, 1e-14);
}

TEST(Thickness, BadInputThrows) {
  const auto sphere = test::icosphere(1);
  Eigen::MatrixXi bad = sphere.F;
  bad(0, 0) = -1;
  EXPECT_THROW(vertex_thickness(sphere.V, bad, sphere.V), InputError);
  EXPECT_THROW(vertex_thickness(sphere.V, Eigen::MatrixXi(0, 3), sphere.V), InputError);
  Eigen::MatrixXd nan = sphere.V;
  nan(1, 1) = std::nan("");
  EXPECT_THROW(vertex_thickness(sphere.V, sphere.F, nan), InputError);
  EXPECT_EQ(vertex_thickness(sphere.V, sphere.F, Eigen::MatrixXd(0, 3)).size(), 0);
}

} // namespace
} // namespace gshell
