// Built-in meshes: valid, closed where they should be, right topology, outward normals, documented counts.
#include <gshell/error.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/geometry/mesh_topology.h>
#include <gshell/geometry/validate_mesh.h>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

using namespace gshell;

namespace {

struct Expected {
  std::string spec;
  int chi, boundary_loops;
  double genus;
};

Eigen::Vector3d face_normal(const TriMesh& m, int f) {
  const Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
  return (b - a).cross(c - a);
}

Eigen::Vector3d centroid(const TriMesh& m, int f) {
  return (m.V.row(m.F(f, 0)) + m.V.row(m.F(f, 1)) + m.V.row(m.F(f, 2))).transpose() / 3.0;
}

double signed_volume(const TriMesh& m) {
  double v = 0;
  for (int f = 0; f < m.num_faces(); ++f) {
    const Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    v += a.dot(b.cross(c)) / 6.0;
  }
  return v;
}

double min_angle_degrees(const TriMesh& m) {
  double smallest = 180;
  for (int f = 0; f < m.num_faces(); ++f)
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d p = m.V.row(m.F(f, k)), q = m.V.row(m.F(f, (k + 1) % 3)), r = m.V.row(m.F(f, (k + 2) % 3));
      const Eigen::Vector3d u = (q - p).normalized(), w = (r - p).normalized();
      smallest = std::min(smallest, std::acos(std::clamp(u.dot(w), -1.0, 1.0)) * 180 / std::numbers::pi);
    }
  return smallest;
}

} // namespace

class BuiltinTopology : public ::testing::TestWithParam<Expected> {};

TEST_P(BuiltinTopology, ValidWithExpectedTopology) {
  const Expected& e = GetParam();
  const TriMesh m = make_builtin(e.spec);
  for (const auto& p : validate_mesh(m))
    EXPECT_EQ(p.severity, MeshProblem::Severity::Info) << e.spec << ": " << p.message;
  EXPECT_NO_THROW(require_valid_mesh(m, e.spec));
  const MeshStats s = mesh_stats(m);
  EXPECT_EQ(s.euler_characteristic, e.chi) << e.spec;
  EXPECT_EQ(s.boundary_loops, e.boundary_loops) << e.spec;
  EXPECT_EQ(s.components, 1) << e.spec;
  EXPECT_EQ(s.unreferenced_vertices, 0) << e.spec;
  EXPECT_DOUBLE_EQ(s.genus, e.genus) << e.spec;
  // Triangles good enough to carry prisms: no slivers anywhere.
  EXPECT_GT(min_angle_degrees(m), 25.0) << e.spec;
}

INSTANTIATE_TEST_SUITE_P(
    AllBuiltins, BuiltinTopology,
    ::testing::Values(Expected{"builtin:sphere", 2, 0, 0}, Expected{"builtin:sphere:0", 2, 0, 0},
                      Expected{"builtin:sphere:2", 2, 0, 0}, Expected{"builtin:torus", 0, 0, 1},
                      Expected{"builtin:torus:6", 0, 0, 1}, Expected{"builtin:torus:33", 0, 0, 1},
                      Expected{"builtin:plane", 1, 1, 0}, Expected{"builtin:plane:1", 1, 1, 0},
                      Expected{"builtin:cylinder", 0, 2, 0}, Expected{"builtin:cylinder:3", 0, 2, 0},
                      Expected{"builtin:bowl", 1, 1, 0}, Expected{"builtin:bowl:2", 1, 1, 0},
                      Expected{"builtin:bowl:17", 1, 1, 0}),
    [](const auto& info) {
      std::string name = info.param.spec.substr(8);
      for (char& c : name)
        if (c == ':') c = '_';
      return name;
    });

TEST(BuiltinMesh, ClosedMeshesEncloseTheirAnalyticVolume) {
  const double pi = std::numbers::pi;
  const TriMesh sphere = make_sphere(5, 2.0);
  EXPECT_GT(signed_volume(sphere), 0.99 * 4.0 / 3.0 * pi * 8.0);
  EXPECT_LT(signed_volume(sphere), 4.0 / 3.0 * pi * 8.0); // inscribed polyhedron
  const TriMesh torus = make_torus(128, 1.0, 0.4);
  EXPECT_NEAR(signed_volume(torus), 2 * pi * pi * 1.0 * 0.4 * 0.4, 0.01 * 2 * pi * pi * 0.16);
}

TEST(BuiltinMesh, EveryFaceNormalPointsOutwards) {
  const TriMesh sphere = make_sphere(3);
  for (int f = 0; f < sphere.num_faces(); ++f) EXPECT_GT(face_normal(sphere, f).dot(centroid(sphere, f)), 0);

  const TriMesh torus = make_torus(32, 1.0, 0.4);
  for (int f = 0; f < torus.num_faces(); ++f) {
    const Eigen::Vector3d c = centroid(torus, f);
    const Eigen::Vector3d ring = Eigen::Vector3d(c.x(), c.y(), 0).normalized(); // tube centre line point
    EXPECT_GT(face_normal(torus, f).dot(c - ring), 0) << f;
  }

  const TriMesh plane = make_plane(8);
  for (int f = 0; f < plane.num_faces(); ++f) EXPECT_GT(face_normal(plane, f).z(), 0) << f;

  const TriMesh cylinder = make_cylinder(24);
  for (int f = 0; f < cylinder.num_faces(); ++f) {
    const Eigen::Vector3d c = centroid(cylinder, f);
    EXPECT_GT(face_normal(cylinder, f).dot(Eigen::Vector3d(c.x(), c.y(), 0)), 0) << f; // away from the axis
  }

  const TriMesh bowl = make_bowl(12);
  for (int f = 0; f < bowl.num_faces(); ++f) {
    EXPECT_GT(face_normal(bowl, f).dot(centroid(bowl, f)), 0) << f; // away from the sphere's centre
    EXPECT_LE(centroid(bowl, f).z(), 1e-12);
  }
}

TEST(BuiltinMesh, CountsFollowTheDocumentedResolution) {
  for (int level = 0; level <= 5; ++level) {
    const TriMesh m = make_builtin("builtin:sphere:" + std::to_string(level));
    const int expected = 10 * (1 << (2 * level)) + 2;
    EXPECT_EQ(m.num_vertices(), expected);
    EXPECT_EQ(m.num_faces(), 2 * expected - 4);
  }
  EXPECT_EQ(make_builtin("builtin:sphere").num_vertices(), 2562);
  for (int res : {6, 7, 40, 64}) {
    const TriMesh m = make_builtin("builtin:torus:" + std::to_string(res));
    EXPECT_EQ(m.num_vertices(), res * (res / 2));
    EXPECT_EQ(m.num_faces(), 2 * res * (res / 2));
  }
  EXPECT_EQ(make_builtin("builtin:torus").num_vertices(), 64 * 32);
  for (int res : {1, 5, 32}) {
    const TriMesh m = make_builtin("builtin:plane:" + std::to_string(res));
    EXPECT_EQ(m.num_vertices(), (res + 1) * (res + 1));
    EXPECT_EQ(m.num_faces(), 2 * res * res);
  }
  EXPECT_EQ(make_builtin("builtin:plane").num_vertices(), 33 * 33);
  for (int res : {3, 10, 64, 100}) {
    const TriMesh m = make_builtin("builtin:cylinder:" + std::to_string(res));
    const int rows = std::max(1, static_cast<int>(std::lround(res / std::numbers::pi)));
    EXPECT_EQ(m.num_vertices(), res * (rows + 1));
    EXPECT_EQ(m.num_faces(), 2 * res * rows);
  }
  EXPECT_EQ(make_builtin("builtin:cylinder").num_vertices(), 64 * 21);
  // Bowl: ~2.6 res^2 vertices (area 2 pi covered by triangles of edge ~ pi/(2 res)).
  for (int res : {10, 20, 40, 80}) {
    const int n = make_builtin("builtin:bowl:" + std::to_string(res)).num_vertices();
    EXPECT_GT(n, 2.4 * res * res) << res;
    EXPECT_LT(n, 2.8 * res * res) << res;
  }
  const int bowl_default = make_builtin("builtin:bowl").num_vertices();
  EXPECT_EQ(bowl_default, make_bowl(40).num_vertices());
  EXPECT_GT(bowl_default, 3800); // ~4K base vertices: a shell of ~8K like the paper's basket
  EXPECT_LT(bowl_default, 4400);
}

TEST(BuiltinMesh, GeometryHasTheDocumentedSize) {
  const TriMesh sphere = make_sphere(2, 3.0);
  EXPECT_NEAR(sphere.V.rowwise().norm().minCoeff(), 3.0, 1e-12);
  EXPECT_NEAR(sphere.V.rowwise().norm().maxCoeff(), 3.0, 1e-12);
  const TriMesh plane = make_plane(4, 2.0);
  EXPECT_DOUBLE_EQ(plane.V.col(0).minCoeff(), -2.0);
  EXPECT_DOUBLE_EQ(plane.V.col(1).maxCoeff(), 2.0);
  const TriMesh cylinder = make_cylinder(16, 0.5, 3.0);
  EXPECT_NEAR(cylinder.V.leftCols(2).rowwise().norm().maxCoeff(), 0.5, 1e-12);
  EXPECT_DOUBLE_EQ(cylinder.V.col(2).minCoeff(), -1.5);
  EXPECT_DOUBLE_EQ(cylinder.V.col(2).maxCoeff(), 1.5);
  const TriMesh bowl = make_bowl(10, 2.0);
  EXPECT_NEAR(bowl.V.rowwise().norm().maxCoeff(), 2.0, 1e-12);
  EXPECT_NEAR(bowl.V.col(2).minCoeff(), -2.0, 1e-12);
  EXPECT_EQ(bowl.V.col(2).maxCoeff(), 0.0); // the rim lies exactly in z = 0
}

TEST(BuiltinMesh, TextureCoordinatesAreCounterClockwiseLikeTheFaces) {
  for (const char* spec : {"builtin:torus:16", "builtin:plane:8", "builtin:cylinder:16", "builtin:bowl:8"}) {
    const TriMesh m = make_builtin(spec);
    ASSERT_TRUE(m.has_uv()) << spec;
    EXPECT_GE(m.UV.minCoeff(), 0.0) << spec;
    EXPECT_LE(m.UV.maxCoeff(), 1.0) << spec;
    double total = 0;
    for (int f = 0; f < m.num_faces(); ++f) {
      const Eigen::Vector2d a = m.UV.row(m.FUV(f, 0)), b = m.UV.row(m.FUV(f, 1)), c = m.UV.row(m.FUV(f, 2));
      const double area = 0.5 * ((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x());
      EXPECT_GT(area, 0) << spec << " face " << f;
      total += area;
    }
    // The UV triangles tile their domain without overlap: unit square, or the disk of radius 1/2.
    const double domain = std::string(spec) == "builtin:bowl:8" ? std::numbers::pi / 4 : 1.0;
    EXPECT_NEAR(total, domain, 0.05 * domain) << spec;
  }
}

TEST(BuiltinMesh, CylinderSharesItsSeamVertices) {
  const TriMesh m = make_cylinder(12);
  EXPECT_EQ(mesh_stats(m).components, 1);
  EXPECT_EQ(mesh_stats(m).boundary_edges, 2 * 12);
}

TEST(BuiltinMesh, SpecsMatchDirectCalls) {
  EXPECT_TRUE(is_builtin_spec("builtin:sphere"));
  EXPECT_FALSE(is_builtin_spec("sphere.obj"));
  EXPECT_TRUE(make_builtin("builtin:torus:20").V.isApprox(make_torus(20).V));
  EXPECT_TRUE(make_builtin("builtin:sphere:1").F == make_sphere(1).F);
  EXPECT_TRUE(make_builtin("builtin:bowl:9").V.isApprox(make_bowl(9).V));
}

TEST(BuiltinMesh, GeneratorsRejectBadParametersNamingThem) {
  const auto message = [](const auto& make) -> std::string {
    try {
      make();
    } catch (const InputError& e) {
      return e.what();
    }
    return "(no InputError)";
  };
  EXPECT_NE(message([] { make_sphere(-1); }).find("level -1 is out of range [0, 9]"), std::string::npos);
  EXPECT_NE(message([] { make_sphere(2, 0.0); }).find("radius must be a positive finite number"), std::string::npos);
  EXPECT_NE(message([] { make_torus(4); }).find("res 4 is out of range"), std::string::npos);
  EXPECT_NE(message([] { make_torus(12, 1.0, std::nan("")); }).find("minor_radius"), std::string::npos);
  EXPECT_NE(message([] { make_plane(0); }).find("res 0"), std::string::npos);
  EXPECT_NE(message([] { make_cylinder(8, 1.0, -2.0); }).find("height"), std::string::npos);
  EXPECT_NE(message([] { make_bowl(1); }).find("res 1"), std::string::npos);
  // The ends of every range are accepted.
  EXPECT_EQ(make_sphere(0).V.rows(), 12);
  EXPECT_EQ(make_plane(1).V.rows(), 4);
}

TEST(BuiltinMesh, BadSpecsThrowInputErrorNamingTheSpec) {
  for (const std::string spec :
       {"builtin:", "builtin:cube", "builtin:sphere:", "builtin:sphere:x", "builtin:sphere:3.5", "builtin:sphere:-1",
        "builtin:sphere:10", "builtin:torus:4", "builtin:torus:99999", "builtin:plane:0", "builtin:cylinder:2",
        "builtin:bowl:1", "builtin:bowl:4:5", "builtin:bowl: 4", "builtin:sphere:99999999999999999999", "model.off"}) {
    try {
      make_builtin(spec);
      ADD_FAILURE() << spec << " did not throw";
    } catch (const InputError& e) {
      const std::string msg = e.what();
      EXPECT_EQ(msg.rfind(spec + ": ", 0), 0u) << msg;
      EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
    }
  }
}

TEST(BuiltinMesh, MidpointSubdivisionKeepsTheSurfaceAndSplitsEveryFaceInFour) {
  // A torus (closed, genus 1) split twice: 16x the faces, V + E vertices per split (E = 3F/2 on a
  // closed mesh), the first V vertices where they were, the same area and enclosed volume (the
  // split is flat), and a valid mesh.
  const TriMesh torus = make_torus(16);
  const TriMesh twice = midpoint_subdivision(torus, 2);
  const int V = torus.num_vertices(), F = torus.num_faces();
  EXPECT_EQ(twice.num_faces(), 16 * F);
  const int once_vertices = V + 3 * F / 2;
  EXPECT_EQ(twice.num_vertices(), once_vertices + 3 * (4 * F) / 2);
  EXPECT_TRUE(twice.V.topRows(V) == torus.V);
  auto area = [](const TriMesh& m) {
    double sum = 0;
    for (int f = 0; f < m.num_faces(); ++f) {
      const Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
      sum += 0.5 * (b - a).cross(c - a).norm();
    }
    return sum;
  };
  EXPECT_NEAR(area(twice), area(torus), 1e-12 * area(torus));
  EXPECT_NEAR(signed_volume(twice), signed_volume(torus), 1e-12 * signed_volume(torus));
  EXPECT_TRUE(validate_mesh(twice).empty());
  EXPECT_TRUE(midpoint_subdivision(torus, 0).V == torus.V);
  EXPECT_THROW(midpoint_subdivision(torus, -1), InputError);
}
