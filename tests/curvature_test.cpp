// Normal-cycle curvature and curvature-sensitive prisms against analytic surfaces.
#include <gshell/error.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/geometry/curvature.h>
#include <gshell/shell/curvature_prisms.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/solver/rest_tets.h>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <queue>
#include <random>
#include <vector>

using namespace gshell;

namespace {

constexpr double kDegree = std::numbers::pi / 180;

Eigen::Vector3d face_normal(const TriMesh& mesh, int f) {
  const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
  return (b - a).cross(c - a).normalized();
}

/// Angle between two lines (directions up to sign), in radians.
double line_angle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::min(1.0, std::abs(a.normalized().dot(b.normalized()))));
}

/// Edge-graph distance of every vertex to the nearest boundary vertex (large when closed).
std::vector<int> distance_to_boundary(const TriMesh& mesh) {
  const int n = mesh.num_vertices();
  std::vector<std::vector<int>> neighbours(n);
  std::map<std::pair<int, int>, int> count;
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int j = 0; j < 3; ++j) {
      const int a = mesh.F(f, j), b = mesh.F(f, (j + 1) % 3);
      neighbours[a].push_back(b);
      neighbours[b].push_back(a);
      ++count[{std::min(a, b), std::max(a, b)}];
    }
  std::vector<int> dist(n, 1 << 30);
  std::queue<int> queue;
  for (const auto& [edge, c] : count)
    if (c == 1)
      for (int v : {edge.first, edge.second})
        if (dist[v] != 0) {
          dist[v] = 0;
          queue.push(v);
        }
  while (!queue.empty()) {
    const int v = queue.front();
    queue.pop();
    for (int w : neighbours[v])
      if (dist[w] > dist[v] + 1) {
        dist[w] = dist[v] + 1;
        queue.push(w);
      }
  }
  return dist;
}

TriMesh flipped(TriMesh mesh) {
  mesh.F.col(1).swap(mesh.F.col(2));
  return mesh;
}

} // namespace

TEST(Curvature, SphereFacesAndVerticesAreUmbilicWithCurvatureOneOverRadius) {
  const double r = 2.0;
  const TriMesh sphere = make_sphere(5, r); // 20480 faces
  const FaceCurvature fc = face_curvature(sphere.V, sphere.F);
  ASSERT_EQ(fc.k1.size(), sphere.num_faces());
  for (int f = 0; f < sphere.num_faces(); ++f) {
    EXPECT_NEAR(fc.k1(f) * r, 1.0, 0.02) << "face " << f;
    EXPECT_NEAR(fc.k2(f) * r, 1.0, 0.02) << "face " << f;
    EXPECT_GE(fc.k1(f), fc.k2(f));
  }
  const VertexCurvature vc = vertex_curvature(sphere.V, sphere.F);
  ASSERT_EQ(vc.k1.size(), sphere.num_vertices());
  for (int v = 0; v < sphere.num_vertices(); ++v) {
    EXPECT_NEAR(vc.k1(v) * r, 1.0, 0.02) << "vertex " << v;
    EXPECT_NEAR(vc.k2(v) * r, 1.0, 0.02) << "vertex " << v;
  }
  EXPECT_NEAR(fc.mean().mean() * r, 1.0, 0.01);
  EXPECT_NEAR(fc.gaussian().mean() * r * r, 1.0, 0.02);
}

TEST(Curvature, DirectionsAreAnOrthonormalFrameInTheFacePlane) {
  const TriMesh torus = make_torus(48);
  const FaceCurvature fc = face_curvature(torus.V, torus.F);
  for (int f = 0; f < torus.num_faces(); ++f) {
    const Eigen::Vector3d n = face_normal(torus, f), e1 = fc.e1.row(f), e2 = fc.e2.row(f);
    EXPECT_NEAR(e1.norm(), 1.0, 1e-12);
    EXPECT_NEAR(e2.norm(), 1.0, 1e-12);
    EXPECT_NEAR(e1.dot(e2), 0.0, 1e-12);
    EXPECT_NEAR(e1.dot(n), 0.0, 1e-12);
    EXPECT_NEAR(e1.cross(e2).dot(n), 1.0, 1e-12); // right-handed (e1, e2, n)
  }
}

TEST(Curvature, CylinderAwayFromTheBoundaryBendsAroundNotAlong) {
  const double r = 1.5;
  const TriMesh cylinder = make_cylinder(96, r, 6.0);
  const FaceCurvature fc = face_curvature(cylinder.V, cylinder.F);
  const std::vector<int> dist = distance_to_boundary(cylinder);
  int checked = 0;
  for (int f = 0; f < cylinder.num_faces(); ++f) {
    // The 2-ring of f touches vertices up to 2 edges from f's own: it is boundary-free when
    // those are 3 or more edges away from the boundary.
    const int d = std::min({dist[cylinder.F(f, 0)], dist[cylinder.F(f, 1)], dist[cylinder.F(f, 2)]});
    if (d < 3) continue;
    ++checked;
    EXPECT_NEAR(fc.k1(f) * r, 1.0, 0.03) << "face " << f;
    EXPECT_NEAR(fc.k2(f) * r, 0.0, 0.03) << "face " << f;
    // Around the circumference, within the facet's plane: the normal is radial.
    const Eigen::Vector3d around = face_normal(cylinder, f).cross(Eigen::Vector3d::UnitZ());
    EXPECT_LT(line_angle(fc.e1.row(f), around), 5 * kDegree) << "face " << f;
    EXPECT_LT(line_angle(fc.e2.row(f), Eigen::Vector3d::UnitZ()), 5 * kDegree) << "face " << f;
  }
  EXPECT_GT(checked, cylinder.num_faces() / 2);
}

TEST(Curvature, PlaneHasZeroCurvature) {
  const TriMesh plane = make_plane(16, 3.0);
  const FaceCurvature fc = face_curvature(plane.V, plane.F);
  EXPECT_LT(fc.k1.cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT(fc.k2.cwiseAbs().maxCoeff(), 1e-12);
  const VertexCurvature vc = vertex_curvature(plane.V, plane.F);
  EXPECT_LT(vc.k1.cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT(vc.k2.cwiseAbs().maxCoeff(), 1e-12);
}

TEST(Curvature, ConvexIsPositiveAndFlippingTheOrientationFlipsTheSigns) {
  for (const TriMesh& mesh : {make_sphere(3, 0.7), make_torus(32), make_bowl(12)}) {
    const FaceCurvature a = face_curvature(mesh.V, mesh.F);
    const FaceCurvature b = face_curvature(mesh.V, flipped(mesh).F);
    const VertexCurvature va = vertex_curvature(mesh.V, mesh.F);
    const VertexCurvature vb = vertex_curvature(mesh.V, flipped(mesh).F);
    const double scale = a.k1.cwiseAbs().maxCoeff();
    for (int f = 0; f < mesh.num_faces(); ++f) {
      EXPECT_NEAR(b.k1(f), -a.k2(f), 1e-9 * scale);
      EXPECT_NEAR(b.k2(f), -a.k1(f), 1e-9 * scale);
      // Where the two curvatures differ, the directions swap roles.
      if (a.k1(f) - a.k2(f) > 1e-3 * scale)
        EXPECT_LT(line_angle(b.e1.row(f), a.e2.row(f)), 1e-6);
    }
    for (int v = 0; v < mesh.num_vertices(); ++v) {
      EXPECT_NEAR(vb.k1(v), -va.k2(v), 1e-9 * scale);
      EXPECT_NEAR(vb.k2(v), -va.k1(v), 1e-9 * scale);
    }
  }
  // Outward normals on a convex surface: positive.
  const TriMesh sphere = make_sphere(3);
  const FaceCurvature c = face_curvature(sphere.V, sphere.F);
  EXPECT_GT(c.k2.minCoeff(), 0.0);
  // Torus: the outer equator is convex both ways, the inner equator is a saddle.
  const TriMesh torus = make_torus(64);
  const FaceCurvature t = face_curvature(torus.V, torus.F);
  for (int f = 0; f < torus.num_faces(); ++f) {
    const Eigen::Vector3d centroid =
        (torus.V.row(torus.F(f, 0)) + torus.V.row(torus.F(f, 1)) + torus.V.row(torus.F(f, 2))) / 3;
    const double rho = std::hypot(centroid.x(), centroid.y());
    if (rho > 1.35) EXPECT_GT(t.k2(f), 0.0);
    if (rho < 0.65) {
      EXPECT_GT(t.k1(f), 0.0);
      EXPECT_LT(t.k2(f), 0.0);
    }
  }
}

TEST(Curvature, RejectsBadInput) {
  const TriMesh sphere = make_sphere(1);
  CurvatureOptions none;
  none.face_rings = 0;
  EXPECT_THROW(face_curvature(sphere.V, sphere.F, none), InputError);
  Eigen::MatrixXi bad = sphere.F;
  bad(0, 0) = sphere.num_vertices();
  EXPECT_THROW(face_curvature(sphere.V, bad), InputError);
  EXPECT_THROW(vertex_curvature(sphere.V, bad), InputError);
}

// ---- curvature-sensitive prisms -------------------------------------------------------------

namespace {

double top_edge(const PrismCorners& P, int f, int j) {
  return (P.row(6 * f + 3 + j) - P.row(6 * f + 3 + (j + 1) % 3)).norm();
}
double base_edge(const PrismCorners& P, int f, int j) {
  return (P.row(6 * f + j) - P.row(6 * f + (j + 1) % 3)).norm();
}

} // namespace

TEST(CurvaturePrisms, PlaneGivesTheNormalPrism) {
  const TriMesh plane = make_plane(8, 2.0);
  int clamped = -1;
  const PrismCorners P = curvature_prisms(plane.V, plane.F, 0.3, 0.5, 2.0, &clamped);
  EXPECT_EQ(clamped, 0);
  ASSERT_EQ(P.rows(), 6 * plane.num_faces());
  EXPECT_LT((P - normal_prisms(plane.V, plane.F, 0.3)).cwiseAbs().maxCoeff(), 1e-12);
  for (int f = 0; f < plane.num_faces(); ++f)
    for (int j = 0; j < 3; ++j) {
      const Eigen::RowVector3d p = plane.V.row(plane.F(f, j));
      EXPECT_LT((P.row(6 * f + j) - p).norm(), 1e-14);
      EXPECT_LT((P.row(6 * f + 3 + j) - (p + Eigen::RowVector3d(0, 0, 0.3))).norm(), 1e-12);
    }
}

TEST(CurvaturePrisms, SphereTopGrowsLikeTheConcentricSphere) {
  const double r = 1.0, eta = 0.2;
  const TriMesh sphere = make_sphere(4, r);
  const PrismCorners P = curvature_prisms(sphere.V, sphere.F, eta);
  for (int f = 0; f < sphere.num_faces(); ++f) {
    const Eigen::Vector3d n = face_normal(sphere, f);
    for (int j = 0; j < 3; ++j) {
      // Curvature within 2% of 1/r: top edges within 2% * eta/r of the exact factor 1 + eta/r.
      EXPECT_NEAR(top_edge(P, f, j) / base_edge(P, f, j), 1 + eta / r, 0.02 * eta / r + 1e-3);
      // Lifted by eta along the face normal: the top stays in a plane parallel to the base.
      const Eigen::Vector3d lift = P.row(6 * f + 3 + j) - P.row(6 * f + j);
      EXPECT_NEAR(lift.dot(n), eta, 1e-12);
    }
  }
}

TEST(CurvaturePrisms, ClampsBindAndAreCounted) {
  const TriMesh sphere = make_sphere(3, 1.0);
  int clamped = -1;
  // 1 + eta * kappa ~ 3 > s_max = 2 everywhere.
  const PrismCorners grow = curvature_prisms(sphere.V, sphere.F, 2.0, 0.5, 2.0, &clamped);
  EXPECT_EQ(clamped, sphere.num_faces());
  for (int f = 0; f < sphere.num_faces(); ++f)
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(top_edge(grow, f, j) / base_edge(grow, f, j), 2.0, 1e-9);
  // Inside-out sphere: 1 + eta * kappa ~ -1 < s_min = 0.5.
  const TriMesh inside = flipped(sphere);
  const PrismCorners shrink = curvature_prisms(inside.V, inside.F, 2.0, 0.5, 2.0, &clamped);
  EXPECT_EQ(clamped, sphere.num_faces());
  for (int f = 0; f < sphere.num_faces(); ++f)
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(top_edge(shrink, f, j) / base_edge(shrink, f, j), 0.5, 1e-9);
  // A thin shell on the same sphere never reaches a clamp.
  curvature_prisms(sphere.V, sphere.F, 0.1, 0.5, 2.0, &clamped);
  EXPECT_EQ(clamped, 0);
}

TEST(CurvaturePrisms, CylinderStretchesAroundOnly) {
  const double r = 1.0, eta = 0.25;
  const TriMesh cylinder = make_cylinder(64, r, 4.0);
  const FaceCurvature fc = face_curvature(cylinder.V, cylinder.F);
  const PrismCorners P = curvature_prisms(cylinder.V, cylinder.F, fc, eta, 0.5, 2.0);
  const std::vector<int> dist = distance_to_boundary(cylinder);
  for (int f = 0; f < cylinder.num_faces(); ++f) {
    if (std::min({dist[cylinder.F(f, 0)], dist[cylinder.F(f, 1)], dist[cylinder.F(f, 2)]}) < 3) continue;
    for (int j = 0; j < 3; ++j) {
      const Eigen::Vector3d base = P.row(6 * f + (j + 1) % 3) - P.row(6 * f + j);
      const Eigen::Vector3d top = P.row(6 * f + 3 + (j + 1) % 3) - P.row(6 * f + 3 + j);
      EXPECT_NEAR(top.z(), base.z(), 1e-9);                                   // along the axis: 1
      const Eigen::Vector3d around = face_normal(cylinder, f).cross(Eigen::Vector3d::UnitZ());
      EXPECT_NEAR(top.dot(around), (1 + eta / r) * base.dot(around), 0.03 * eta * base.norm());
    }
  }
}

TEST(CurvaturePrisms, StrongAnisotropyIsLimitedSoEveryTetKeepsItsVolume) {
  // Separate random triangles in the z=0 plane with a made-up curvature: s_1 = 3, s_2 = 0.55,
  // e_1 at every angle. Irregular triangles scaled that unevenly get twisted side quads.
  const int m = 300;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  TriMesh plane;
  plane.V.resize(3 * m, 3);
  plane.F.resize(m, 3);
  for (int f = 0; f < m; ++f) {
    Eigen::Vector3d p[3];
    do {
      for (auto& q : p) q << unit(rng), unit(rng), 0;
    } while ((p[1] - p[0]).cross(p[2] - p[0]).z() < 0.05); // counter-clockwise, not degenerate
    for (int j = 0; j < 3; ++j) plane.V.row(3 * f + j) = p[j].transpose();
    plane.F.row(f) << 3 * f, 3 * f + 1, 3 * f + 2;
  }
  const double eta = 0.2, s_min = 0.5;
  FaceCurvature fake;
  fake.k1 = Eigen::VectorXd::Constant(m, 2.0 / eta);
  fake.k2 = Eigen::VectorXd::Constant(m, -0.45 / eta);
  fake.e1.resize(m, 3);
  fake.e2.resize(m, 3);
  for (int f = 0; f < m; ++f) {
    const double angle = std::numbers::pi * f / m;
    fake.e1.row(f) << std::cos(angle), std::sin(angle), 0;
    fake.e2.row(f) << -std::sin(angle), std::cos(angle), 0;
  }
  CurvaturePrismStats stats;
  const PrismCorners P = curvature_prisms(plane.V, plane.F, fake, eta, s_min, 4.0, &stats);
  const double s1s2 = 3.0 * 0.55;
  EXPECT_EQ(stats.clamped, 0);
  EXPECT_GT(stats.limited, 0); // without the limit some tets would be too thin or inverted
  EXPECT_LT(stats.limited, m);
  const Eigen::MatrixXi C = prism_tet_corners(plane.F);
  Eigen::MatrixXd corners(4 * C.rows(), 3);
  for (int f = 0; f < m; ++f) {
    auto corner = [&](int c) { return Eigen::Vector3d(P.row(6 * f + c).transpose()); };
    const double area = 0.5 * (corner(1) - corner(0)).cross(corner(2) - corner(0)).norm();
    const double top_area = 0.5 * (corner(4) - corner(3)).cross(corner(5) - corner(3)).norm();
    EXPECT_NEAR(top_area, s1s2 * area, 1e-9); // the limit keeps s_1 s_2, hence the top's area
    for (int k = 0; k < 3; ++k) {
      const int t = 3 * f + k;
      Eigen::Matrix3d D;
      for (int j = 0; j < 3; ++j) D.col(j) = corner(C(t, j + 1)) - corner(C(t, 0));
      EXPECT_GE(D.determinant() / 6, s_min * s_min * eta * area / 3 * (1 - 1e-9)) << "face " << f;
      for (int j = 0; j < 4; ++j) corners.row(4 * t + j) = P.row(6 * f + C(t, j));
    }
  }
  EXPECT_NO_THROW(rest_tets_from_corners(build_prism_tets(plane.F, plane.num_vertices()), corners));
}

TEST(CurvaturePrisms, RejectsBadClampsAndThickness) {
  const TriMesh sphere = make_sphere(1);
  EXPECT_THROW(curvature_prisms(sphere.V, sphere.F, 0.1, 0.0, 2.0), InputError);
  EXPECT_THROW(curvature_prisms(sphere.V, sphere.F, 0.1, 1.5, 2.0), InputError);
  EXPECT_THROW(curvature_prisms(sphere.V, sphere.F, 0.1, 0.5, 0.9), InputError);
  EXPECT_THROW(curvature_prisms(sphere.V, sphere.F, 0.1, 0.5, std::nan("")), InputError);
  EXPECT_THROW(curvature_prisms(sphere.V, sphere.F, -0.1, 0.5, 2.0), InputError);
  EXPECT_NO_THROW(curvature_prisms(sphere.V, sphere.F, 0.1, 1.0, 1.0));
}
