// Validation: every problem kind is found on a small hand-made mesh and named by its index;
// clean meshes pass; topology statistics stay sane on broken meshes.
#include <gshell/error.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/geometry/mesh_topology.h>
#include <gshell/geometry/validate_mesh.h>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

using namespace gshell;
using Severity = MeshProblem::Severity;

namespace {

TriMesh mesh_of(std::vector<Eigen::Vector3d> v, std::vector<Eigen::Vector3i> f) {
  TriMesh m;
  m.V.resize(static_cast<Eigen::Index>(v.size()), 3);
  for (size_t i = 0; i < v.size(); ++i) m.V.row(static_cast<Eigen::Index>(i)) = v[i].transpose();
  m.F.resize(static_cast<Eigen::Index>(f.size()), 3);
  for (size_t i = 0; i < f.size(); ++i) m.F.row(static_cast<Eigen::Index>(i)) = f[i].transpose();
  return m;
}

/// Closed tetrahedron, outward-oriented.
TriMesh tetrahedron() {
  return mesh_of({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}});
}

/// Two triangles forming the unit square, consistently oriented.
TriMesh square() { return mesh_of({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, {{0, 1, 2}, {0, 2, 3}}); }

std::vector<MeshProblem> of_severity(const std::vector<MeshProblem>& all, Severity s) {
  std::vector<MeshProblem> out;
  for (const auto& p : all)
    if (p.severity == s) out.push_back(p);
  return out;
}

/// The single error of `m`; fails the test if there is not exactly one.
std::string only_error(const TriMesh& m) {
  const auto errors = of_severity(validate_mesh(m), Severity::Error);
  if (errors.size() != 1u) {
    std::string all;
    for (const auto& e : errors) all += "\n  error: " + e.message;
    ADD_FAILURE() << errors.size() << " errors instead of 1:" << all;
  }
  return errors.empty() ? std::string() : errors.front().message;
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

} // namespace

TEST(ValidateMesh, CleanClosedMeshHasNoProblemsAtAll) {
  EXPECT_TRUE(validate_mesh(tetrahedron()).empty());
  EXPECT_NO_THROW(require_valid_mesh(tetrahedron(), "tet"));
}

TEST(ValidateMesh, OpenSurfaceIsOnlyInformation) {
  const auto problems = validate_mesh(square());
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems[0].severity, Severity::Info);
  EXPECT_TRUE(contains(problems[0].message, "1 boundary loop")) << problems[0].message;
  EXPECT_NO_THROW(require_valid_mesh(square(), "square"));

  const auto tube = validate_mesh(make_cylinder(8));
  ASSERT_EQ(tube.size(), 1u);
  EXPECT_TRUE(contains(tube[0].message, "2 boundary loops")) << tube[0].message;
}

TEST(ValidateMesh, EmptyMesh) {
  TriMesh none;
  auto p = validate_mesh(none);
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p[0].severity, Severity::Error);
  EXPECT_TRUE(contains(p[0].message, "empty"));
  TriMesh no_faces = tetrahedron();
  no_faces.F.resize(0, 3);
  p = validate_mesh(no_faces);
  ASSERT_EQ(p.size(), 1u);
  EXPECT_TRUE(contains(p[0].message, "no faces"));
  try {
    require_valid_mesh(none, "empty.off");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "empty.off: mesh is empty (no vertices)");
  }
}

TEST(ValidateMesh, NonFiniteCoordinates) {
  TriMesh m = tetrahedron();
  m.V(2, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(contains(only_error(m), "vertex 2 ")) << only_error(m);
  m = tetrahedron();
  m.V(3, 0) = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(contains(only_error(m), "vertex 3 "));
}

TEST(ValidateMesh, TextureCoordinatesMustBeFiniteAndInRange) {
  TriMesh m = tetrahedron();
  m.UV = Eigen::MatrixXd::Zero(4, 2);
  m.UV.col(0) << 0, 1, 0, 1;
  m.FUV = m.F;
  EXPECT_TRUE(validate_mesh(m).empty());
  EXPECT_NO_THROW(require_usable_texture_coordinates(m, "t.obj"));

  TriMesh bad = m;
  bad.UV(2, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(contains(only_error(bad), "texture coordinate 2 is not finite")) << only_error(bad);
  try {
    require_usable_texture_coordinates(bad, "t.obj");
    ADD_FAILURE() << "NaN texture coordinate accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "t.obj: texture coordinate 2 is not finite (NaN or infinity)");
  }
  bad = m;
  bad.FUV(3, 1) = 4;
  EXPECT_TRUE(contains(only_error(bad), "face 3 has texture coordinate id 4 out of range [0, 4)")) << only_error(bad);
  bad = m;
  bad.FUV.conservativeResize(3, 3); // a row of ids missing: not one per face
  EXPECT_TRUE(contains(only_error(bad), "one row of 3 ids per face")) << only_error(bad);
  EXPECT_THROW(require_usable_texture_coordinates(bad, "t.obj"), InputError);
}

TEST(ValidateMesh, TooLargeCoordinatesAreOneClearError) {
  // |x| ~ 1e150 used to pass validation and fail later as "rest tet 0 has non-positive volume
  // (inf)", and 1e200 as "face 0 has zero area" (squared lengths overflow).
  for (const double big : {1e50, 1e150, 1e200, 1.7e308}) {
    TriMesh m = tetrahedron();
    m.V(3, 2) = big;
    const std::string error = only_error(m);
    EXPECT_TRUE(contains(error, "vertex 3 has a coordinate of magnitude ")) << error;
    EXPECT_TRUE(contains(error, "gshell needs |x| < 1e+50")) << error;
    EXPECT_FALSE(contains(error, "zero area")) << error;
  }
  TriMesh m = tetrahedron();
  m.V(1, 0) = -1e200;
  EXPECT_TRUE(contains(only_error(m), "vertex 1 has a coordinate of magnitude 1e+200;")) << only_error(m);
  // Just below the limit is fine, also for the whole mesh.
  m = tetrahedron();
  m.V *= 0.99 * max_coordinate_magnitude;
  EXPECT_TRUE(validate_mesh(m).empty());
  // A mesh entirely beyond the limit: one entry per vertex, no zero-area noise.
  m = tetrahedron();
  m.V.array() += 1e120;
  const auto errors = of_severity(validate_mesh(m), Severity::Error);
  ASSERT_EQ(errors.size(), 4u);
  for (const auto& e : errors) EXPECT_TRUE(contains(e.message, "magnitude 1e+120")) << e.message;
}

TEST(ValidateMesh, TooSmallMeshIsOneClearError) {
  // At 1e-150 the areas underflow and every face read as "zero area".
  for (const double tiny : {1e-41, 1e-150, 1e-300}) {
    TriMesh m = tetrahedron();
    m.V *= tiny;
    const std::string error = only_error(m);
    EXPECT_TRUE(contains(error, "the mesh is too small: its bounding box diagonal is ")) << error;
    EXPECT_TRUE(contains(error, "gshell needs at least 1e-40")) << error;
  }
  TriMesh m = tetrahedron();
  m.V *= 1e-40; // diagonal 1.4e-40
  EXPECT_TRUE(validate_mesh(m).empty());
  // All vertices at one point is not "too small" but degenerate.
  m = tetrahedron();
  m.V.setConstant(3);
  const auto errors = of_severity(validate_mesh(m), Severity::Error);
  ASSERT_FALSE(errors.empty());
  EXPECT_TRUE(contains(errors[0].message, "zero area")) << errors[0].message;
}

TEST(ValidateMesh, RequireUsableCoordinatesNamesTheInputAndVertex) {
  Eigen::MatrixXd V = tetrahedron().V;
  EXPECT_NO_THROW(require_usable_coordinates(V, "top.obj"));
  V(2, 0) = 2e51;
  try {
    require_usable_coordinates(V, "top.obj");
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "top.obj: vertex 2 has a coordinate of magnitude 2e+51; gshell needs |x| < 1e+50 "
                                     "(volumes and products of lengths would overflow)");
  }
  V(1, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(require_usable_coordinates(V, "top.obj"), InputError);
}

TEST(ValidateMesh, OutOfRangeIndices) {
  TriMesh m = tetrahedron();
  m.F(1, 2) = 4;
  auto errors = of_severity(validate_mesh(m), Severity::Error);
  ASSERT_FALSE(errors.empty());
  EXPECT_TRUE(contains(errors[0].message, "face 1 ")) << errors[0].message;
  EXPECT_TRUE(contains(errors[0].message, "out of range")) << errors[0].message;
  m.F(1, 2) = -1;
  errors = of_severity(validate_mesh(m), Severity::Error);
  ASSERT_FALSE(errors.empty());
  EXPECT_TRUE(contains(errors[0].message, "face 1 ")) << errors[0].message;
}

TEST(ValidateMesh, RepeatedIndices) {
  TriMesh m = square();
  m.F(1, 2) = 0; // face 1 = (0, 2, 0)
  const auto errors = of_severity(validate_mesh(m), Severity::Error);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_TRUE(contains(errors[0].message, "face 1 ")) << errors[0].message;
  EXPECT_TRUE(contains(errors[0].message, "repeat")) << errors[0].message;
}

TEST(ValidateMesh, ZeroAreaFacesRelativeToTheMeshScale) {
  // Face 1's three vertices are collinear.
  TriMesh m = mesh_of({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}}, {{0, 1, 2}, {0, 3, 1}});
  const std::string error = only_error(m);
  EXPECT_TRUE(contains(error, "face 1 ")) << error;
  EXPECT_TRUE(contains(error, "zero area")) << error;
  // Coincident positions with distinct indices are zero-area too.
  m = mesh_of({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 0, 0}}, {{0, 1, 2}, {0, 3, 1}});
  EXPECT_TRUE(contains(only_error(m), "face 1 "));
  // A tiny mesh is not degenerate: the threshold follows the mesh's size.
  TriMesh tiny = tetrahedron();
  tiny.V *= 1e-9;
  EXPECT_TRUE(of_severity(validate_mesh(tiny), Severity::Error).empty());
  // A sliver 1e-9 wide inside a unit-size mesh is fine; 1e-14 is not.
  m = mesh_of({{0, 0, 0}, {1, 0, 0}, {0.5, 1e-9, 0}, {0, 1, 0}}, {{0, 1, 2}, {0, 2, 3}});
  EXPECT_TRUE(of_severity(validate_mesh(m), Severity::Error).empty());
  m.V(2, 1) = 1e-14;
  EXPECT_TRUE(contains(only_error(m), "face 0 "));
  // zero_area_faces (for deformation frames, which may have them) follows the same rule.
  EXPECT_EQ(zero_area_faces(m.V, m.F), std::vector<int>{0});
  m.V(2, 1) = 1e-9;
  EXPECT_TRUE(zero_area_faces(m.V, m.F).empty());
  EXPECT_TRUE(zero_area_faces(tiny.V, tiny.F).empty());
}

TEST(ValidateMesh, AVertexNoFaceUsesDoesNotSetTheScaleOfZeroArea) {
  // A stray vertex a million sizes away (a leftover pivot) made every face "zero area" against the
  // box it widened; it is a warning, and the faces are measured against the surface's own box.
  TriMesh m = tetrahedron();
  const Eigen::Index stray = m.V.rows();
  m.V.conservativeResize(stray + 1, 3);
  m.V.row(stray) << 1e7, 0, 0;
  const std::vector<MeshProblem> problems = validate_mesh(m);
  EXPECT_TRUE(of_severity(problems, Severity::Error).empty());
  const auto warnings = of_severity(problems, Severity::Warning);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_TRUE(contains(warnings[0].message, "used by no face")) << warnings[0].message;
  EXPECT_TRUE(zero_area_faces(m.V, m.F).empty());
  // A really flat face of that surface is still one.
  m.V.row(3) = m.V.row(0);
  EXPECT_FALSE(of_severity(validate_mesh(m), Severity::Error).empty());
  EXPECT_FALSE(zero_area_faces(m.V, m.F).empty());
}

TEST(ValidateMesh, ZeroAreaFacesRefusesIndicesOutOfRange) {
  TriMesh m = tetrahedron();
  m.F(2, 1) = 99999;
  try {
    zero_area_faces(m.V, m.F);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_TRUE(contains(e.what(), "face 2 has vertex index 99999 out of range [0, 4)")) << e.what();
  }
  m.F(2, 1) = -1;
  EXPECT_THROW(zero_area_faces(m.V, m.F), InputError);
}

TEST(ValidateMesh, NonManifoldEdge) {
  // Three triangles on edge (0, 1).
  const TriMesh m = mesh_of({{0, 0, 0}, {1, 0, 0}, {0.5, 1, 0}, {0.5, -1, 0}, {0.5, 0, 1}},
                            {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}});
  const auto errors = of_severity(validate_mesh(m), Severity::Error);
  ASSERT_FALSE(errors.empty());
  EXPECT_TRUE(contains(errors[0].message, "edge (0, 1) is non-manifold")) << errors[0].message;
  EXPECT_TRUE(contains(errors[0].message, "3 faces (0, 1, 2)")) << errors[0].message;
  const MeshStats s = mesh_stats(m); // stays usable on a broken mesh
  EXPECT_EQ(s.edges, 7);
  EXPECT_EQ(s.components, 1);
}

TEST(ValidateMesh, NonManifoldVertex) {
  // Bow tie: two triangles touching only at vertex 0.
  TriMesh m = mesh_of({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {-1, 0, 0}, {-1, -1, 0}}, {{0, 1, 2}, {0, 3, 4}});
  std::string error = only_error(m);
  EXPECT_TRUE(contains(error, "vertex 0 is non-manifold")) << error;
  // Two closed tetrahedra sharing one vertex: every edge is fine, the vertex is not.
  m = mesh_of({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}},
              {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}, {0, 5, 4}, {0, 4, 6}, {0, 6, 5}, {4, 5, 6}});
  for (int f = 4; f < 8; ++f) std::swap(m.F(f, 1), m.F(f, 2)); // mirrored copy: flip back outward
  error = only_error(m);
  EXPECT_TRUE(contains(error, "vertex 0 is non-manifold")) << error;
  EXPECT_TRUE(contains(error, "2 separate fans")) << error;
}

TEST(ValidateMesh, InconsistentOrientation) {
  TriMesh m = square();
  std::swap(m.F(1, 1), m.F(1, 2)); // face 1 = (0, 3, 2) runs 2->0 along the shared edge, like face 0
  const std::string error = only_error(m);
  EXPECT_TRUE(contains(error, "faces 0 and 1 are oriented inconsistently")) << error;
  // A closed mesh with one flipped face is caught at each of its three edges.
  m = tetrahedron();
  std::swap(m.F(3, 1), m.F(3, 2));
  EXPECT_EQ(of_severity(validate_mesh(m), Severity::Error).size(), 3u);
}

TEST(ValidateMesh, DuplicatedFaceIsNamedOnceWhateverItsOrientation) {
  // One triangle twice, opposite ways round: every edge has two faces running along it in opposite
  // directions, which the edge checks alone took for a closed surface (enclosing nothing).
  std::string error = only_error(mesh_of({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}, {0, 2, 1}}));
  EXPECT_TRUE(contains(error, "faces 0 and 1 use the same three vertices (0, 1, 2)")) << error;
  // The same way round: not an orientation clash on each of its edges but one duplicated face.
  error = only_error(mesh_of({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}, {1, 2, 0}}));
  EXPECT_TRUE(contains(error, "faces 0 and 1 use the same three vertices")) << error;
  // A closed tetrahedron with one face repeated: not three non-manifold edges.
  TriMesh m = tetrahedron();
  m.F.conservativeResize(5, 3);
  m.F.row(4) = m.F.row(1);
  error = only_error(m);
  EXPECT_TRUE(contains(error, "faces 1 and 4 use the same three vertices (0, 1, 3)")) << error;
  // Faces sharing two vertices only are no duplicates: the clean closed mesh has none.
  EXPECT_TRUE(validate_mesh(tetrahedron()).empty());
}

TEST(ValidateMesh, UnreferencedVertexIsAWarning) {
  TriMesh m = tetrahedron();
  m.V.conservativeResize(5, 3);
  m.V.row(4) << 5, 5, 5;
  const auto problems = validate_mesh(m);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems[0].severity, Severity::Warning);
  EXPECT_TRUE(contains(problems[0].message, "vertex 4 ")) << problems[0].message;
  EXPECT_NO_THROW(require_valid_mesh(m, "m"));
  EXPECT_EQ(mesh_stats(m).unreferenced_vertices, 1);
  EXPECT_EQ(mesh_stats(m).euler_characteristic, 2);
}

TEST(ValidateMesh, BoundaryLoopsAreCounted) {
  // Two separate triangles: two loops.
  const TriMesh m = mesh_of({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {5, 0, 0}, {6, 0, 0}, {5, 1, 0}}, {{0, 1, 2}, {3, 4, 5}});
  const auto problems = validate_mesh(m);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_TRUE(contains(problems[0].message, "2 boundary loops")) << problems[0].message;
  EXPECT_TRUE(contains(problems[0].message, "6 boundary edges")) << problems[0].message;
  const MeshStats s = mesh_stats(m);
  EXPECT_EQ(s.boundary_loops, 2);
  EXPECT_EQ(s.components, 2);
  EXPECT_DOUBLE_EQ(s.genus, 0);
}

TEST(ValidateMesh, ErrorsComeFirstAndRequireValidMeshCountsTheRest) {
  TriMesh m = tetrahedron();
  m.V.conservativeResize(5, 3);
  m.V.row(4) << 5, 5, 5; // warning
  m.V(1, 0) = std::numeric_limits<double>::quiet_NaN(); // error
  m.F(3, 0) = 7;                                        // error (face 3 out of range) + open boundary info
  const auto problems = validate_mesh(m);
  ASSERT_GE(problems.size(), 4u);
  EXPECT_EQ(problems[0].severity, Severity::Error);
  EXPECT_EQ(problems[1].severity, Severity::Error);
  EXPECT_EQ(problems[2].severity, Severity::Warning);
  EXPECT_EQ(problems.back().severity, Severity::Info);
  try {
    require_valid_mesh(m, "broken.off");
    FAIL();
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind("broken.off: vertex 1 ", 0), 0u) << msg;
    EXPECT_TRUE(contains(msg, "(and 2 more problems)")) << msg;
  }
}

TEST(ValidateMesh, ManyProblemsOfOneKindAreSummarised) {
  // 25 faces with zero area (all vertices at the origin, scale from one extra far vertex).
  TriMesh m;
  m.V = Eigen::MatrixXd::Zero(76, 3);
  m.V.row(75) << 1, 1, 1;
  m.F.resize(25, 3);
  for (int f = 0; f < 25; ++f) m.F.row(f) << 3 * f, 3 * f + 1, 3 * f + 2;
  const auto errors = of_severity(validate_mesh(m), Severity::Error);
  ASSERT_EQ(errors.size(), 11u);
  EXPECT_TRUE(contains(errors.back().message, "15 more zero-area faces")) << errors.back().message;
  EXPECT_EQ(errors.back().count, 15);
  try {
    require_valid_mesh(m, "m");
    FAIL();
  } catch (const InputError& e) {
    // 24 faces, vertex 75 (unreferenced) and 74 of the 75 boundary vertices at the origin (cut)
    EXPECT_TRUE(contains(e.what(), "(and 99 more problems)")) << e.what();
  }
}

TEST(MeshTopology, StatsOfATetrahedron) {
  const MeshStats s = mesh_stats(tetrahedron());
  EXPECT_EQ(s.vertices, 4);
  EXPECT_EQ(s.faces, 4);
  EXPECT_EQ(s.edges, 6);
  EXPECT_EQ(s.boundary_loops, 0);
  EXPECT_EQ(s.components, 1);
  EXPECT_EQ(s.euler_characteristic, 2);
  EXPECT_DOUBLE_EQ(s.genus, 0);
  EXPECT_EQ(s.bbox_min, Eigen::Vector3d(0, 0, 0));
  EXPECT_EQ(s.bbox_max, Eigen::Vector3d(1, 1, 1));
  EXPECT_NEAR(s.mean_edge_length, (3 + 3 * std::sqrt(2.0)) / 6, 1e-12);
}

TEST(MeshTopology, GenusOfTwoTori) {
  TriMesh a = make_torus(12), b = make_torus(12);
  TriMesh both;
  both.V.resize(a.V.rows() * 2, 3);
  both.V << a.V, (b.V.rowwise() + Eigen::RowVector3d(5, 0, 0));
  both.F.resize(a.F.rows() * 2, 3);
  both.F << a.F, (b.F.array() + static_cast<int>(a.V.rows())).matrix();
  const MeshStats s = mesh_stats(both);
  EXPECT_EQ(s.components, 2);
  EXPECT_EQ(s.euler_characteristic, 0);
  EXPECT_DOUBLE_EQ(s.genus, 2); // total over components
}

TEST(MeshTopology, UniqueEdgesInOrderOfFirstAppearance) {
  Eigen::MatrixXi F(2, 3);
  F << 2, 0, 1, 0, 3, 1;
  Eigen::MatrixXi expected(5, 2);
  expected << 0, 2, 0, 1, 1, 2, 0, 3, 1, 3;
  EXPECT_EQ(unique_edges(F), expected);
}

TEST(MeshTopology, StatsSurviveOutOfRangeIndicesAndNaN) {
  TriMesh m = tetrahedron();
  m.F(0, 0) = 100;
  m.F(1, 1) = -5;
  m.V(2, 2) = std::numeric_limits<double>::quiet_NaN();
  const MeshStats s = mesh_stats(m);
  EXPECT_EQ(s.faces, 4);
  EXPECT_EQ(s.edges, 5); // faces 2 and 3 only
  EXPECT_TRUE(s.bbox_min.allFinite());
}

TEST(ValidateMesh, WrongMatrixShapesAreErrorsNotCrashes) {
  TriMesh m = tetrahedron();
  m.V = Eigen::MatrixXd::Zero(4, 2);
  auto errors = of_severity(validate_mesh(m), Severity::Error);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_TRUE(contains(errors[0].message, "3 coordinates"));
  EXPECT_EQ(mesh_stats(m).edges, 0);
  m = tetrahedron();
  m.F = Eigen::MatrixXi::Zero(2, 4);
  errors = of_severity(validate_mesh(m), Severity::Error);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(mesh_stats(m).edges, 0);
}

TEST(MeshTopology, StatsAgreeWithTheEdgeTable) {
  // mesh_stats walks vertex stars; edge_incidence builds a global edge table: two independent
  // ways to the same counts, also on a messy mesh (non-manifold, flipped, isolated pieces).
  TriMesh messy = make_bowl(6);
  const int n = messy.num_vertices();
  messy.F.conservativeResize(messy.F.rows() + 4, 3);
  messy.F.bottomRows(4) << 0, 1, n - 1, 1, 0, n - 2, 2, 3, 4, n - 3, n - 2, n - 1; // extra faces on edges
  for (const TriMesh& m : {make_sphere(2), make_torus(10), make_cylinder(9), make_bowl(7), messy}) {
    const MeshStats s = mesh_stats(m);
    const EdgeIncidence inc = edge_incidence(m.F, m.num_vertices());
    int boundary = 0;
    for (int e = 0; e < inc.num_edges(); ++e) boundary += inc.valence(e) == 1;
    EXPECT_EQ(s.edges, inc.num_edges());
    EXPECT_EQ(s.boundary_edges, boundary);
    EXPECT_EQ(s.boundary_loops, count_boundary_loops(inc, m.num_vertices()));
    EXPECT_EQ(unique_edges(m.F), inc.edges);
  }
}

TEST(MeshTopology, InwardClosedPartsAreTheClosedPartsEnclosingANegativeVolume) {
  // Two spheres and a torus side by side, far from the origin; the second sphere and the torus
  // with their faces reversed. Open surfaces, reversed too, have no inside, even where their
  // faces sum to a negative volume (the bowl, both ways round).
  auto reversed = [](TriMesh m) {
    m.F.col(1).swap(m.F.col(2));
    return m;
  };
  const std::vector<TriMesh> parts = {make_sphere(2), reversed(make_sphere(2)), reversed(make_torus(16)),
                                      reversed(make_plane(4)), make_bowl(8), reversed(make_bowl(8))};
  TriMesh all;
  int rows = 0, faces = 0;
  for (const TriMesh& p : parts) rows += static_cast<int>(p.V.rows()), faces += static_cast<int>(p.F.rows());
  all.V.resize(rows, 3);
  all.F.resize(faces, 3);
  std::vector<int> first;
  rows = faces = 0;
  for (std::size_t k = 0; k < parts.size(); ++k) {
    first.push_back(rows);
    all.V.middleRows(rows, parts[k].V.rows()) = parts[k].V.rowwise() + Eigen::RowVector3d(1e6 + 3.0 * k, 0, 0);
    all.F.middleRows(faces, parts[k].F.rows()) = parts[k].F.array() + rows;
    rows += static_cast<int>(parts[k].V.rows());
    faces += static_cast<int>(parts[k].F.rows());
  }
  EXPECT_EQ(inward_closed_parts(all.V, all.F), (std::vector<int>{first[1], first[2]}));
  EXPECT_TRUE(inward_closed_parts(make_sphere(2).V, make_sphere(2).F).empty());
  EXPECT_TRUE(inward_closed_parts(tetrahedron().V, tetrahedron().F).empty());
  const TriMesh inside_out = reversed(tetrahedron());
  EXPECT_EQ(inward_closed_parts(inside_out.V, inside_out.F), std::vector<int>{0});
  // Two sheets face to face enclose nothing: no side to name.
  TriMesh sheets = make_plane(2);
  const Eigen::Index m = sheets.F.rows();
  sheets.F.conservativeResize(2 * m, 3);
  sheets.F.bottomRows(m) = reversed(make_plane(2)).F;
  EXPECT_TRUE(inward_closed_parts(sheets.V, sheets.F).empty());
  EXPECT_TRUE(inward_closed_parts_message({}).empty());
  EXPECT_TRUE(contains(inward_closed_parts_message({first[1], first[2]}), "2 closed parts have their faces pointing inwards"));
  EXPECT_TRUE(contains(inward_closed_parts_message({7}), "the part with vertex 7"));
}
