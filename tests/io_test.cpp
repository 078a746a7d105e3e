// Mesh I/O: round trips through every format keep positions, faces, UVs and vertex order exactly;
// hand-written files in every variant (OBJ forms, OFF prefixes, PLY encodings and types, STL
// ASCII/binary) read as they should; malformed files of every kind throw InputError naming the
// file, fast and without huge allocations; writes are atomic.
#include <gshell/error.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/io/atomic_file.h>
#include <gshell/io/read_mesh.h>
#include <gshell/io/tet_mesh_io.h>
#include <gshell/io/write_mesh.h>

#include "test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

using namespace gshell;
using gshell::test::TempDir;
using gshell::test::read_text;
using gshell::test::write_text;

namespace {

constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();

/// A mesh whose coordinates need all 17 digits, with vertices listed in a scrambled order (and
/// one unreferenced vertex) so any reordering by a reader or writer would show.
TriMesh awkward_mesh() {
  TriMesh m = make_torus(12);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> noise(-1e-3, 1e-3);
  for (Eigen::Index i = 0; i < m.V.rows(); ++i)
    for (int k = 0; k < 3; ++k) m.V(i, k) = m.V(i, k) / 3.0 + noise(rng);
  m.V(0, 0) = 1e-300;
  m.V(1, 1) = -123456789.123456789;
  // Reverse the vertex order and append one unreferenced vertex.
  const Eigen::Index n = m.V.rows();
  Eigen::MatrixXd V(n + 1, 3);
  for (Eigen::Index i = 0; i < n; ++i) V.row(i) = m.V.row(n - 1 - i);
  V.row(n) << 0.1, 0.2, 0.3;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) m.F(f, k) = static_cast<int>(n - 1 - m.F(f, k));
  m.V = V;
  return m;
}

void expect_same_geometry(const TriMesh& a, const TriMesh& b) {
  ASSERT_EQ(a.V.rows(), b.V.rows());
  ASSERT_EQ(a.F.rows(), b.F.rows());
  EXPECT_TRUE(a.V == b.V) << "positions or vertex order changed";
  EXPECT_TRUE(a.F == b.F) << "faces changed";
}

/// Little helpers to write binary files by hand, in either byte order.
struct Bytes {
  std::string s;
  template <class T>
  Bytes& put(T value, bool big_endian) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &value, sizeof(T));
    const bool native_big = std::endian::native == std::endian::big;
    if (big_endian != native_big)
      for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
    s.append(reinterpret_cast<const char*>(b), sizeof(T));
    return *this;
  }
};

/// Expects read_mesh(path) to throw InputError whose one-line message names the file.
void expect_input_error(const std::string& path, const std::string& fragment = "") {
  try {
    read_mesh(path);
    ADD_FAILURE() << "no error for " << path;
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(path), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << "message is not one line: " << what;
    if (!fragment.empty()) EXPECT_NE(what.find(fragment), std::string::npos) << what;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "wrong exception type for " << path << ": " << e.what();
  }
}

/// A reader may accept or refuse a damaged file, but only through InputError.
void expect_no_crash(const std::string& path) {
  try {
    read_mesh(path);
  } catch (const InputError&) {
  } catch (const std::exception& e) {
    ADD_FAILURE() << "unexpected exception for " << path << ": " << e.what();
  }
}

TriMesh read_text_mesh(const TempDir& dir, const std::string& name, const std::string& content) {
  const std::string path = dir.file(name);
  write_text(path, content);
  return read_mesh(path);
}

// ---------------------------------------------------------------------------------------------
// Round trips

TEST(IoRoundTrip, EveryFormatKeepsPositionsFacesAndVertexOrderExactly) {
  TempDir dir;
  const TriMesh m = awkward_mesh();
  for (const std::string name : {"m.obj", "m.off", "m.ply", "m.OBJ"}) {
    SCOPED_TRACE(name);
    write_mesh(dir.file(name), m);
    expect_same_geometry(m, read_mesh(dir.file(name)));
  }
  write_mesh(dir.file("ascii.ply"), m, {}, true);
  expect_same_geometry(m, read_mesh(dir.file("ascii.ply")));
  EXPECT_EQ(read_text(dir.file("ascii.ply")).rfind("ply\nformat ascii 1.0\n", 0), 0u);
  EXPECT_EQ(read_text(dir.file("m.ply")).rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
}

TEST(IoRoundTrip, ObjKeepsTextureCoordinates) {
  TempDir dir;
  const TriMesh m = make_torus(10); // UV grid with seams: UV ids differ from vertex ids
  ASSERT_TRUE(m.has_uv());
  write_mesh(dir.file("t.obj"), m);
  const TriMesh r = read_mesh(dir.file("t.obj"));
  expect_same_geometry(m, r);
  ASSERT_TRUE(r.has_uv());
  EXPECT_TRUE(r.UV == m.UV);
  EXPECT_TRUE(r.FUV == m.FUV);
  // Formats without per-corner UVs drop them, never returning inconsistent ones.
  write_mesh(dir.file("t.off"), m);
  EXPECT_FALSE(read_mesh(dir.file("t.off")).has_uv());
}

TEST(IoRoundTrip, NonFiniteCoordinatesAreReadNotRejected) {
  TempDir dir;
  TriMesh m = make_sphere(0);
  m.V(3, 1) = nan_value;
  m.V(5, 2) = std::numeric_limits<double>::infinity();
  for (const std::string name : {"n.obj", "n.off", "n.ply"}) {
    write_mesh(dir.file(name), m);
    const TriMesh r = read_mesh(dir.file(name));
    EXPECT_TRUE(std::isnan(r.V(3, 1))) << name;
    EXPECT_TRUE(std::isinf(r.V(5, 2)) && r.V(5, 2) > 0) << name;
  }
}

TEST(IoRoundTrip, PlyWritesColorsAndScalarsAsNamedProperties) {
  TempDir dir;
  const TriMesh m = make_sphere(1);
  const Eigen::Index n = m.V.rows(), f = m.F.rows();
  MeshAttributes a;
  a.vertex_colors.resize(n, 3);
  a.face_colors.resize(f, 3);
  for (Eigen::Index i = 0; i < n; ++i) a.vertex_colors.row(i) << i % 256, (3 * i) % 256, 255;
  for (Eigen::Index i = 0; i < f; ++i) a.face_colors.row(i) << 7, i % 256, 0;
  a.vertex_scalars.emplace_back("thickness", Eigen::VectorXd::LinSpaced(n, 0.0, 1.0));
  a.face_scalars.emplace_back("stretch", Eigen::VectorXd::LinSpaced(f, -1.0, 2.0));
  write_mesh(dir.file("a.ply"), m, a);

  // Decode the file independently of the reader: header text, then the little-endian body.
  const std::string bytes = read_text(dir.file("a.ply"));
  const std::string header_end = "end_header\n";
  const std::size_t body = bytes.find(header_end) + header_end.size();
  const std::string header = bytes.substr(0, body);
  EXPECT_EQ(header, "ply\nformat binary_little_endian 1.0\ncomment gshell\nelement vertex " + std::to_string(n) +
                        "\nproperty double x\nproperty double y\nproperty double z\nproperty uchar red\n"
                        "property uchar green\nproperty uchar blue\nproperty double thickness\nelement face " +
                        std::to_string(f) +
                        "\nproperty list uchar int vertex_indices\nproperty uchar red\nproperty uchar green\n"
                        "property uchar blue\nproperty double stretch\nend_header\n");
  const std::size_t vertex_size = 3 * 8 + 3 + 8, face_size = 1 + 3 * 4 + 3 + 8;
  ASSERT_EQ(bytes.size(), body + n * vertex_size + f * face_size);
  auto f64 = [&](std::size_t at) {
    double v;
    std::memcpy(&v, bytes.data() + at, 8);
    return v;
  };
  for (Eigen::Index i = 0; i < n; ++i) {
    const std::size_t at = body + i * vertex_size;
    EXPECT_EQ(f64(at), m.V(i, 0));
    EXPECT_EQ(static_cast<unsigned char>(bytes[at + 24]), a.vertex_colors(i, 0));
    EXPECT_EQ(static_cast<unsigned char>(bytes[at + 25]), a.vertex_colors(i, 1));
    EXPECT_EQ(f64(at + 27), a.vertex_scalars[0].second[i]);
  }
  for (Eigen::Index i = 0; i < f; ++i) {
    const std::size_t at = body + n * vertex_size + i * face_size;
    EXPECT_EQ(bytes[at], 3);
    std::int32_t id;
    std::memcpy(&id, bytes.data() + at + 5, 4);
    EXPECT_EQ(id, m.F(i, 1));
    EXPECT_EQ(static_cast<unsigned char>(bytes[at + 14]), a.face_colors(i, 1));
    EXPECT_EQ(f64(at + 16), a.face_scalars[0].second[i]);
  }
  // The reader skips the extra properties, in both encodings.
  expect_same_geometry(m, read_mesh(dir.file("a.ply")));
  write_mesh(dir.file("b.ply"), m, a, true);
  expect_same_geometry(m, read_mesh(dir.file("b.ply")));
  const std::string ascii = read_text(dir.file("b.ply"));
  const std::size_t first_line = ascii.find(header_end) + header_end.size();
  const std::string first_vertex = ascii.substr(first_line, ascii.find('\n', first_line) - first_line);
  EXPECT_TRUE(first_vertex.ends_with(" 0 0 255 0")) << "colors and scalar follow the position: " << first_vertex;
  // OFF keeps colors as COFF vertex colors and face colors after the indices.
  write_mesh(dir.file("c.off"), m, a);
  EXPECT_EQ(read_text(dir.file("c.off")).rfind("COFF\n", 0), 0u);
  expect_same_geometry(m, read_mesh(dir.file("c.off")));
}

TEST(IoRoundTrip, WritersRejectInconsistentArgumentsAsInputErrorsAndWriteNothing) {
  TempDir dir;
  const TriMesh m = make_sphere(0);
  MeshAttributes bad_name;
  bad_name.vertex_scalars.emplace_back("two words", Eigen::VectorXd::Zero(m.V.rows()));
  EXPECT_THROW(write_mesh(dir.file("x.ply"), m, bad_name), InputError);
  MeshAttributes bad_size;
  bad_size.face_scalars.emplace_back("s", Eigen::VectorXd::Zero(3));
  EXPECT_THROW(write_mesh(dir.file("x.ply"), m, bad_size), InputError);
  TriMesh bad_index = m;
  bad_index.F(0, 1) = static_cast<int>(m.V.rows());
  EXPECT_THROW(write_mesh(dir.file("x.obj"), bad_index), InputError);
  // No vertices: every reader refuses such a file, so it is not written (with vertices and no
  // faces it reads back).
  for (const char* name : {"x.obj", "x.off", "x.ply"})
    EXPECT_THROW(write_mesh(dir.file(name), TriMesh{}), InputError) << name;
  TempDir other;
  TriMesh points;
  points.V = m.V;
  write_mesh(other.file("points.obj"), points);
  EXPECT_EQ(read_mesh(other.file("points.obj")).V.rows(), m.V.rows());
  TetMesh tets;
  tets.X = Eigen::MatrixXd::Zero(4, 3);
  tets.T = (Eigen::MatrixXi(1, 4) << 0, 1, 2, 4).finished(); // vertex 4 of 4
  EXPECT_THROW(write_tet_mesh(dir.file("x.vtu"), tets), InputError);
  tets.T(0, 3) = 3;
  tets.cell_data.emplace_back("stretch", Eigen::MatrixXd::Zero(2, 1)); // one tet, two values
  EXPECT_THROW(write_tet_mesh(dir.file("x.vtu"), tets), InputError);
  EXPECT_EQ(gshell::test::count_entries(dir.path()), 0);
}

// ---------------------------------------------------------------------------------------------
// Hand-written files: OBJ

TEST(IoObj, ReadsAllCornerFormsNegativeIndicesPolygonsAndUvs) {
  TempDir dir;
  const TriMesh m = read_text_mesh(dir, "a.obj",
                                   "# comment\nmtllib x.mtl\no thing\n"
                                   "v 0 0 0\nv 1 0 0\nv 1 1 0 1.0\nv 0 1 0 0.5 0.5 0.5\n"
                                   "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1 0\nvn 0 0 1\n"
                                   "g group\nusemtl m\ns off\n"
                                   "f 1/1/1 2/2/1 3/3/1 4/4/1\n"   // quad -> fan
                                   "f -4/-4 -2/-2 -1/-1\n");       // relative indices
  ASSERT_EQ(m.V.rows(), 4);
  EXPECT_EQ(m.V(2, 1), 1.0);
  ASSERT_EQ(m.F.rows(), 3);
  EXPECT_EQ(m.F.row(0), Eigen::RowVector3i(0, 1, 2));
  EXPECT_EQ(m.F.row(1), Eigen::RowVector3i(0, 2, 3));
  EXPECT_EQ(m.F.row(2), Eigen::RowVector3i(0, 2, 3));
  ASSERT_TRUE(m.has_uv());
  EXPECT_EQ(m.UV.rows(), 4);
  EXPECT_EQ(m.UV(2, 0), 1.0);
  EXPECT_EQ(m.FUV.row(2), Eigen::RowVector3i(0, 2, 3));

  const TriMesh n = read_text_mesh(dir, "b.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//1\n");
  EXPECT_EQ(n.F.row(0), Eigen::RowVector3i(0, 1, 2));
  EXPECT_FALSE(n.has_uv());
  // Positive indices may refer to vertices defined later.
  const TriMesh later = read_text_mesh(dir, "c.obj", "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n");
  EXPECT_EQ(later.F.rows(), 1);
  // UVs on only some faces are dropped rather than left inconsistent.
  const TriMesh partial = read_text_mesh(dir, "d.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\n"
                                                       "f 1/1 2/1 3/1\nf 2 4 3\n");
  EXPECT_FALSE(partial.has_uv());
  EXPECT_TRUE(partial.UV.rows() == 0 && partial.FUV.rows() == 0);
  // ... and not silently: read_mesh says so, naming the file (the fan of a quad counts once).
  write_text(dir.file("e.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 2 2 0\nvt 0 0\n"
                                "f 1/1 2/1 4/1 3/1\nf 2 5 4\n");
  std::vector<std::string> warnings;
  EXPECT_FALSE(read_mesh(dir.file("e.obj"), &warnings).has_uv());
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], dir.file("e.obj") + ": 1 of 2 faces have no texture coordinates: all are dropped (a texture "
                                             "needs every face in the UV layout)");
  // A file without any vt, or with them on every face, warns of nothing.
  warnings.clear();
  read_mesh(dir.file("b.obj"), &warnings);
  read_mesh(dir.file("a.obj"), &warnings);
  EXPECT_TRUE(warnings.empty());
}

TEST(IoObj, ABackslashAtTheEndOfALineContinuesTheStatement) {
  TempDir dir;
  // A face and a vertex split over lines (the backslash alone, attached to a token, followed by
  // blanks and a CR), and an ignored statement continued: its second line is not a statement.
  const TriMesh m = read_text_mesh(dir, "a.obj",
                                   "v 0 0 0\nv 1 \\\n 0 0\nv 1 1 0\nv 0 1 0\n"
                                   "g a \\\n  b\n"
                                   "f 1 2 \\\n 3\\ \r\n 4\n"
                                   "f 1 3 4 \\");
  ASSERT_EQ(m.V.rows(), 4);
  EXPECT_EQ(m.V.row(1), Eigen::RowVector3d(1, 0, 0));
  ASSERT_EQ(m.F.rows(), 3);
  EXPECT_EQ(m.F.row(0), Eigen::RowVector3i(0, 1, 2));
  EXPECT_EQ(m.F.row(1), Eigen::RowVector3i(0, 2, 3));
  EXPECT_EQ(m.F.row(2), Eigen::RowVector3i(0, 2, 3));
  // Errors after a continuation name the line they are on.
  write_text(dir.file("bad.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 \\\n 2 x\n");
  expect_input_error(dir.file("bad.obj"), "line 5");
  // A backslash inside a line is not a continuation.
  write_text(dir.file("mid.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 \\ 2 3\n");
  expect_input_error(dir.file("mid.obj"), "line 4");
}

TEST(IoObj, MalformedContentNamesFileAndLine) {
  TempDir dir;
  auto check = [&](const std::string& content, const std::string& fragment) {
    const std::string path = dir.file("bad.obj");
    write_text(path, content);
    expect_input_error(path, fragment);
  };
  check("v 0 0 0\nv 1 0 x\n", "line 2");
  check("v 0 0 0\nv 1 0\n", "line 2");
  check("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", "line 4");
  check("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "line 4");
  check("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", "line 4");
  check("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n", "line 4");
  check("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n", "line 5");
  check("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2 3/1\n", "line 5");
  check("v 0 0 0\nhello world\n", "line 2");
  check("", "empty");
  check("# only a comment\n", "empty");
}

// ---------------------------------------------------------------------------------------------
// OFF

TEST(IoOff, ReadsVariantsCommentsAndPolygons) {
  TempDir dir;
  const TriMesh plain = read_text_mesh(dir, "a.off",
                                       "OFF\n# a comment line\n4 2 0\n0 0 0\n1 0 0 # trailing comment\n1 1 0\n"
                                       "\n0 1 0\n4 0 1 2 3\n3 0 2 3 255 0 0\n");
  ASSERT_EQ(plain.V.rows(), 4);
  ASSERT_EQ(plain.F.rows(), 3);
  EXPECT_EQ(plain.F.row(0), Eigen::RowVector3i(0, 1, 2));
  EXPECT_EQ(plain.F.row(1), Eigen::RowVector3i(0, 2, 3));
  EXPECT_EQ(plain.F.row(2), Eigen::RowVector3i(0, 2, 3));

  const TriMesh coff = read_text_mesh(dir, "b.off", "COFF 3 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n"
                                                    "0 1 0 0.1 0.2 0.3 1.0\n3 0 1 2\n");
  EXPECT_EQ(coff.V(1, 0), 1.0);
  EXPECT_EQ(coff.F.rows(), 1);
  const TriMesh noff = read_text_mesh(dir, "c.off", "NOFF\n3 1 0\n0 0 0 0 0 1\n2 0 0 0 0 1\n0 2 0 0 0 1\n3 0 1 2\n");
  EXPECT_EQ(noff.V(2, 1), 2.0);
  const TriMesh cnoff = read_text_mesh(dir, "d.off", "CNOFF\n3 1\n0 0 0 0 0 1 1 1 1\n2 0 0 0 0 1 1 1 1\n"
                                                     "0 2 0 0 0 1 1 1 1\n3 0 1 2\n");
  EXPECT_EQ(cnoff.V.rows(), 3);
  const TriMesh headerless = read_text_mesh(dir, "e.off", "3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 2 1 0\n");
  EXPECT_EQ(headerless.F.row(0), Eigen::RowVector3i(2, 1, 0));
  const TriMesh crlf = read_text_mesh(dir, "f.off", "OFF\r\n3 1 0\r\n0 0 0\r\n1 0 0\r\n0 1 0\r\n3 0 1 2\r\n");
  EXPECT_EQ(crlf.F.rows(), 1);
}

TEST(IoOff, WrongCountsAndBadValuesAreErrors) {
  TempDir dir;
  auto check = [&](const std::string& content, const std::string& fragment = "") {
    const std::string path = dir.file("bad.off");
    write_text(path, content);
    expect_input_error(path, fragment);
  };
  const std::string verts = "0 0 0\n1 0 0\n0 1 0\n";
  check("OFF\n3 2 0\n" + verts + "3 0 1 2\n", "faces");            // fewer faces than announced
  check("OFF\n3 1 0\n" + verts + "3 0 1 2\n3 0 2 1\n", "wrong counts"); // more than announced
  check("OFF\n4 1 0\n" + verts + "3 0 1 2\n", "");                  // fewer vertices than announced
  check("OFF\n3 1 0\n0 0 0\n1 0 z\n0 1 0\n3 0 1 2\n", "line 4");
  check("OFF\n3 1 0\n" + verts + "3 0 1 3\n", "line 6");
  check("OFF\n3 1 0\n" + verts + "3 0 1\n", "line 6");
  check("OFF\n3 1 0\n" + verts + "2 0 1\n", "line 6");
  check("OFF\n3 1 0\n0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "line 3");
  check("OFF\n-3 1 0\n", "negative");
  check("4OFF\n3 1 0\n", "4D");
  check("OFF BINARY\n", "binary");
  check("PLY\n3 1 0\n", "not an OFF file");
  check("OFF\n1000000000000 1 0\n" + verts, "too large");
  check("OFF\n100000000 100000000 0\n" + verts + "3 0 1 2\n", "bytes");
}

// ---------------------------------------------------------------------------------------------
// PLY

std::string ply_header(const std::string& format, const std::string& vertex_props, long long nv,
                       const std::string& face_props, long long nf, const std::string& extra = "") {
  return "ply\nformat " + format + " 1.0\ncomment hand made\nelement vertex " + std::to_string(nv) + "\n" +
         vertex_props + extra + "element face " + std::to_string(nf) + "\n" + face_props + "end_header\n";
}

/// Square as two faces (quad + triangle) with float/double coordinates and a skipped property.
std::string binary_ply(bool big, bool double_coordinates, const std::string& count_type, const std::string& index_type) {
  const std::string coord = double_coordinates ? "double" : "float";
  std::string header = ply_header(big ? "binary_big_endian" : "binary_little_endian",
                                  "property " + coord + " x\nproperty " + coord + " y\nproperty " + coord +
                                      " z\nproperty float confidence\n",
                                  4, "property list " + count_type + " " + index_type + " vertex_indices\nproperty int flags\n", 2);
  Bytes b;
  b.s = header;
  const double xyz[4][3] = {{0, 0, 0}, {1.5, 0, 0}, {1.5, 1.25, 0}, {0, 1.25, -0.5}};
  for (const auto& p : xyz) {
    for (double v : p) {
      if (double_coordinates) b.put<double>(v, big);
      else b.put<float>(static_cast<float>(v), big);
    }
    b.put<float>(0.75f, big);
  }
  const std::vector<std::vector<int>> faces = {{0, 1, 2, 3}, {3, 2, 1}};
  for (const auto& f : faces) {
    if (count_type == "uchar") b.put<std::uint8_t>(static_cast<std::uint8_t>(f.size()), big);
    else b.put<std::int32_t>(static_cast<std::int32_t>(f.size()), big);
    for (int id : f) {
      if (index_type == "uint") b.put<std::uint32_t>(static_cast<std::uint32_t>(id), big);
      else b.put<std::int32_t>(id, big);
    }
    b.put<std::int32_t>(-1, big);
  }
  return b.s;
}

void expect_square(const TriMesh& m) {
  ASSERT_EQ(m.V.rows(), 4);
  EXPECT_EQ(m.V(1, 0), 1.5);
  EXPECT_EQ(m.V(2, 1), 1.25);
  EXPECT_EQ(m.V(3, 2), -0.5);
  ASSERT_EQ(m.F.rows(), 3);
  EXPECT_EQ(m.F.row(0), Eigen::RowVector3i(0, 1, 2));
  EXPECT_EQ(m.F.row(1), Eigen::RowVector3i(0, 2, 3));
  EXPECT_EQ(m.F.row(2), Eigen::RowVector3i(3, 2, 1));
}

TEST(IoPly, ReadsBothEndiannessesAndAllCommonTypes) {
  TempDir dir;
  for (bool big : {false, true})
    for (bool dbl : {false, true})
      for (const std::string count : {"uchar", "int"})
        for (const std::string index : {"int", "uint"}) {
          SCOPED_TRACE(std::string(big ? "big" : "little") + (dbl ? " double " : " float ") + count + " " + index);
          expect_square(read_text_mesh(dir, "s.ply", binary_ply(big, dbl, count, index)));
        }
}

TEST(IoPly, ReadsAsciiWithExtraElementsAndProperties) {
  TempDir dir;
  const std::string header =
      "ply\r\nformat ascii 1.0\r\nobj_info made by hand\r\nelement vertex 4\r\nproperty float x\r\n"
      "property float y\r\nproperty float z\r\nproperty uchar red\r\nproperty list uchar float extra\r\n"
      "element face 2\r\nproperty list uchar int vertex_indices\r\nelement edge 1\r\nproperty int a\r\n"
      "property int b\r\nend_header\r\n";
  const std::string body = "0 0 0 1 0\n1.5 0 0 2 1 9.5\n1.5 1.25 0 3 2 1 2\n0 1.25 -0.5 4 0\n"
                           "4 0 1 2 3\n3 3 2 1\n0 1\n";
  expect_square(read_text_mesh(dir, "a.ply", header + body));
}

TEST(IoRead, NamesTheDataItDoesNotKeepOnceEach) {
  TempDir dir;
  auto skipped = [&](const std::string& name, const std::string& content) {
    write_text(dir.file(name), content);
    std::vector<std::string> names;
    read_mesh(dir.file(name), nullptr, &names);
    return names;
  };
  using Names = std::vector<std::string>;
  const std::string tri = "3 0 1 2";
  EXPECT_EQ(skipped("plain.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n" + tri + "\n"), Names{});
  EXPECT_EQ(skipped("c.off", "COFF\n3 1 0\n0 0 0 1 0 0 1\n1 0 0 1 0 0 1\n0 1 0 1 0 0 1\n" + tri + " 255 0 0\n"),
            (Names{"vertex colors", "face colors"}));
  EXPECT_EQ(skipped("cn.off", "CNOFF\n3 1 0\n0 0 0 0 0 1 1 1 1\n1 0 0 0 0 1 1 1 1\n0 1 0 0 0 1 1 1 1\n" + tri + "\n"),
            (Names{"normals", "vertex colors"}));
  // OBJ: a fourth value is a weight, three or more a color.
  EXPECT_EQ(skipped("w.obj", "v 0 0 0 1\nv 1 0 0 1\nv 0 1 0 1\nf 1 2 3\n"), Names{});
  EXPECT_EQ(skipped("c.obj", "mtllib m.mtl\nv 0 0 0 1 0 0\nv 1 0 0 1 0 0\nv 0 1 0 1 0 0\nvn 0 0 1\nf 1//1 2//1 3//1\n"),
            (Names{"materials", "vertex colors", "normals"}));
  const std::string header = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                             "property float z\nproperty float nx\nelement face 1\n"
                             "property list uchar int vertex_indices\nproperty uchar red\n";
  EXPECT_EQ(skipped("a.ply", header + "element edge 0\nproperty int a\nend_header\n0 0 0 1\n1 0 0 1\n0 1 0 1\n3 0 1 2 9\n"),
            (Names{"vertex property 'nx'", "face property 'red'"}));
  EXPECT_EQ(skipped("b.ply", header + "element edge 1\nproperty int a\nend_header\n0 0 0 1\n1 0 0 1\n0 1 0 1\n3 0 1 2 9\n5\n"),
            (Names{"vertex property 'nx'", "face property 'red'", "'edge' elements"}));
  // At most 16 names, however many properties a header lists.
  std::string many = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
  for (int k = 0; k < 40; ++k) many += "property float p" + std::to_string(k) + "\n";
  many += "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  std::string zeros;
  for (int k = 0; k < 40; ++k) zeros += " 0";
  many += "0 0 0" + zeros + "\n1 0 0" + zeros + "\n0 1 0" + zeros + "\n";
  many += tri + "\n";
  EXPECT_EQ(skipped("many.ply", many).size(), 16u);
}

TEST(IoPly, MalformedFilesAreErrors) {
  TempDir dir;
  const std::string good = binary_ply(false, false, "uchar", "int");
  auto check = [&](const std::string& content, const std::string& fragment = "") {
    const std::string path = dir.file("bad.ply");
    write_text(path, content);
    expect_input_error(path, fragment);
  };
  check(good + std::string(1, '\0'), "wrong length");            // one byte too many
  check(good.substr(0, good.size() - 1), "truncated");             // one byte short
  check(good.substr(0, good.find("end_header")), "end_header");  // header cut
  check("plx\n" + good.substr(4), "not a PLY file");
  check("ply\nformat binary_middle_endian 1.0\nend_header\n", "format");
  check("ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n", "type");
  check("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n", "x, y and z");
  check("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0\n",
        "truncated");
  check("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
        "0 0 0\n0 0 0\n",
        "wrong counts");
  check("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 bad 0\n3 0 1 2\n",
        "line 12");
  check("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
        "out of range");
  // Counts far beyond the data: refused before anything is allocated.
  Bytes huge_vertices;
  huge_vertices.s = ply_header("binary_little_endian", "property float x\nproperty float y\nproperty float z\n",
                               1000000000000LL, "property list uchar int vertex_indices\n", 0);
  check(huge_vertices.s, "too large");
  Bytes many_vertices;
  many_vertices.s = ply_header("binary_little_endian", "property float x\nproperty float y\nproperty float z\n",
                               1000000000LL, "property list uchar int vertex_indices\n", 0);
  check(many_vertices.s + std::string(100, '\0'), "truncated or wrong counts");
  Bytes huge_list;
  huge_list.s = ply_header("binary_big_endian", "property float x\nproperty float y\nproperty float z\n", 3,
                           "property list uint uint vertex_indices\n", 1);
  for (int i = 0; i < 9; ++i) huge_list.put<float>(0.f, true);
  huge_list.put<std::uint32_t>(4000000000u, true).put<std::uint32_t>(0, true);
  check(huge_list.s, "past the end");
}

// ---------------------------------------------------------------------------------------------
// STL

const char* ascii_square_stl =
    "solid square\n"
    "  facet normal 0 0 1\n    outer loop\n      vertex 0 0 0\n      vertex 1 0 0\n      vertex 1 1 0\n"
    "    endloop\n  endfacet\n"
    "  facet normal 0 0 1\n    outer loop\n      vertex 0 0 0\n      vertex 1 1 0\n      vertex -0 1 0\n"
    "    endloop\n  endfacet\n"
    "endsolid square\n";

std::string binary_square_stl(const std::string& header_text) {
  Bytes b;
  b.s = header_text;
  b.s.resize(80, ' ');
  b.put<std::uint32_t>(2, false);
  const float tris[2][3][3] = {{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}}, {{0, 0, 0}, {1, 1, 0}, {-0.f, 1, 0}}};
  for (const auto& t : tris) {
    for (int k = 0; k < 3; ++k) b.put<float>(k == 2 ? 1.f : 0.f, false);
    for (const auto& p : t)
      for (float v : p) b.put<float>(v, false);
    b.put<std::uint16_t>(0, false);
  }
  return b.s;
}

void expect_stl_square(const TriMesh& m) {
  // Shared corners become one vertex each, numbered in order of first appearance.
  ASSERT_EQ(m.V.rows(), 4);
  EXPECT_EQ(m.V.row(0), Eigen::RowVector3d(0, 0, 0));
  EXPECT_EQ(m.V.row(1), Eigen::RowVector3d(1, 0, 0));
  EXPECT_EQ(m.V.row(2), Eigen::RowVector3d(1, 1, 0));
  EXPECT_EQ(m.V.row(3), Eigen::RowVector3d(0, 1, 0));
  ASSERT_EQ(m.F.rows(), 2);
  EXPECT_EQ(m.F.row(0), Eigen::RowVector3i(0, 1, 2));
  EXPECT_EQ(m.F.row(1), Eigen::RowVector3i(0, 2, 3));
}

TEST(IoStl, ReadsAsciiAndBinaryMergingCornersInOrder) {
  TempDir dir;
  expect_stl_square(read_text_mesh(dir, "a.stl", ascii_square_stl));
  expect_stl_square(read_text_mesh(dir, "b.stl", binary_square_stl("binary square")));
  // Binary files whose header starts with "solid" are still binary.
  expect_stl_square(read_text_mesh(dir, "c.stl", binary_square_stl("solid but binary")));
  // Upper case keywords, no normal values given, two solids.
  const TriMesh upper = read_text_mesh(dir, "d.STL",
                                       "SOLID x\nFACET NORMAL 0 0 1\nOUTER LOOP\nVERTEX 0 0 0\nVERTEX 1 0 0\n"
                                       "VERTEX 0 1 0\nENDLOOP\nENDFACET\nENDSOLID x\nsolid y\nfacet\nouter loop\n"
                                       "vertex 1 0 0\nvertex 1 1 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid\n");
  EXPECT_EQ(upper.V.rows(), 4);
  EXPECT_EQ(upper.F.row(1), Eigen::RowVector3i(1, 3, 2));
  // NaN is read (validation reports it), not merged with other points.
  const TriMesh with_nan = read_text_mesh(dir, "e.stl",
                                          "solid n\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex nan 0 0\n"
                                          "vertex 0 1 0\nendloop\nendfacet\nendsolid n\n");
  ASSERT_EQ(with_nan.V.rows(), 3);
  EXPECT_TRUE(std::isnan(with_nan.V(1, 0)));
}

// Thousands of corners: the merge's table grows many times over (ASCII, whose triangle count is
// not known ahead) or is sized once (binary). Every corner is the one vertex of its position, the
// vertices numbered in order of first appearance.
TEST(IoStl, ManyCornersMergeIntoOneVertexEachInOrderOfFirstAppearance) {
  TempDir dir;
  const TriMesh sphere = make_sphere(4);
  std::string ascii = "solid sphere\n";
  Bytes binary;
  binary.s.resize(80, ' ');
  binary.put<std::uint32_t>(static_cast<std::uint32_t>(sphere.F.rows()), false);
  std::vector<int> first_seen(sphere.V.rows(), -1); // sphere vertex -> expected id
  std::vector<int> order;
  char line[128];
  for (Eigen::Index f = 0; f < sphere.F.rows(); ++f) {
    ascii += "facet normal 0 0 0\nouter loop\n";
    for (int k = 0; k < 3; ++k) binary.put<float>(0, false);
    for (int k = 0; k < 3; ++k) {
      const int v = sphere.F(f, k);
      if (first_seen[v] < 0) first_seen[v] = static_cast<int>(order.size()), order.push_back(v);
      const Eigen::RowVector3f p = sphere.V.row(v).cast<float>(); // exact in both files
      std::snprintf(line, sizeof line, "vertex %.17g %.17g %.17g\n", double(p(0)), double(p(1)), double(p(2)));
      ascii += line;
      for (int c = 0; c < 3; ++c) binary.put<float>(p(c), false);
    }
    ascii += "endloop\nendfacet\n";
    binary.put<std::uint16_t>(0, false);
  }
  ascii += "endsolid sphere\n";
  for (const std::string& bytes : {ascii, binary.s}) {
    const TriMesh m = read_text_mesh(dir, "s.stl", bytes);
    ASSERT_EQ(m.V.rows(), static_cast<Eigen::Index>(order.size()));
    for (std::size_t i = 0; i < order.size(); ++i)
      ASSERT_EQ(m.V.row(static_cast<Eigen::Index>(i)), sphere.V.row(order[i]).cast<float>().cast<double>());
    ASSERT_EQ(m.F.rows(), sphere.F.rows());
    for (Eigen::Index f = 0; f < m.F.rows(); ++f)
      for (int k = 0; k < 3; ++k) ASSERT_EQ(m.F(f, k), first_seen[sphere.F(f, k)]);
  }
}

TEST(IoStl, MalformedFilesAreErrors) {
  TempDir dir;
  auto check = [&](const std::string& content, const std::string& fragment = "") {
    const std::string path = dir.file("bad.stl");
    write_text(path, content);
    expect_input_error(path, fragment);
  };
  const std::string ascii = ascii_square_stl;
  check(ascii.substr(0, ascii.find("endsolid")), "endsolid");
  check(ascii.substr(0, ascii.find("endloop")), "endloop");
  check("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 q\nendloop\nendfacet\nendsolid\n",
        "line 6");
  check("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\nvertex 2 2 0\n"
        "endloop\nendfacet\nendsolid\n",
        "more than 3");
  check("hello, I am a text file\n", "not an STL file");
  check("", "empty");
  const std::string binary = binary_square_stl("b");
  check(binary.substr(0, binary.size() - 1), "bytes");
  check(binary + "x", "bytes");
  check(std::string(50, '\1'), "too short");
  Bytes huge;
  huge.s = std::string(80, '\0');
  huge.put<std::uint32_t>(4000000000u, false);
  check(huge.s, "truncated");
}

// ---------------------------------------------------------------------------------------------
// Everything else that can be wrong with an input file

TEST(IoErrors, MissingFileUnknownExtensionFolder) {
  TempDir dir;
  expect_input_error(dir.file("missing.obj"), "no such file");
  write_text(dir.file("mesh.xyz"), "whatever");
  expect_input_error(dir.file("mesh.xyz"), ".xyz");
  write_text(dir.file("noextension"), "whatever");
  expect_input_error(dir.file("noextension"), "unknown mesh format");
  std::filesystem::create_directory(dir.file("folder.off"));
  expect_input_error(dir.file("folder.off"), "directory");
  // Without an extension: a missing path (a mistyped folder) or a folder is named as such, not
  // as a file of an unknown format.
  expect_input_error(dir.file("missing"), "no such file");
  std::filesystem::create_directory(dir.file("folder"));
  expect_input_error(dir.file("folder"), "is a directory");
}

// Regular files are mapped, anything else (a pipe here) is read into memory: both give the same
// mesh, and an empty file is refused as empty rather than mapped.
TEST(IoErrors, APipeReadsAsItsFileAndAnEmptyFileIsRefused) {
  TempDir dir;
  const TriMesh mesh = make_sphere(2);
  write_mesh(dir.file("sphere.off"), mesh);
  const std::string pipe = dir.file("pipe.off");
  ASSERT_EQ(mkfifo(pipe.c_str(), 0600), 0);
  std::thread writer([&] {
    std::ofstream(pipe, std::ios::binary) << read_text(dir.file("sphere.off"));
  });
  const TriMesh through_pipe = read_mesh(pipe);
  writer.join();
  const TriMesh from_file = read_mesh(dir.file("sphere.off"));
  EXPECT_EQ(through_pipe.V, from_file.V);
  EXPECT_EQ(through_pipe.F, from_file.F);
  EXPECT_EQ(from_file.F, mesh.F);
  write_text(dir.file("empty.obj"), "");
  expect_input_error(dir.file("empty.obj"), "empty");
}

TEST(IoErrors, GarbageIsRefusedByEveryReader) {
  TempDir dir;
  std::mt19937 rng(11);
  for (const std::string ext : {"obj", "off", "ply", "stl"})
    for (int trial = 0; trial < 20; ++trial) {
      std::string bytes(1 + rng() % 3000, '\0');
      for (char& c : bytes) c = static_cast<char>(rng());
      const std::string path = dir.file("garbage." + ext);
      write_text(path, bytes);
      expect_input_error(path);
    }
}

TEST(IoErrors, TruncatedFilesAreRefusedAndNoPrefixCrashes) {
  TempDir dir;
  const TriMesh m = make_sphere(1);
  for (const std::string name : {"t.obj", "t.off", "t.ply", "ta.ply"}) {
    SCOPED_TRACE(name);
    write_mesh(dir.file(name), m, {}, name == "ta.ply");
    const std::string bytes = read_text(dir.file(name));
    const std::string cut = dir.file("cut." + name.substr(name.find('.') + 1));
    write_text(cut, bytes.substr(0, bytes.size() / 2));
    // OBJ has no counts: a cut OBJ is a smaller valid mesh or refers to missing vertices.
    if (name != "t.obj") expect_input_error(cut);
    for (std::size_t length = 0; length < bytes.size(); length += 1 + length / 16) {
      write_text(cut, bytes.substr(0, length));
      expect_no_crash(cut);
    }
  }
  // Binary files: every proper prefix is an error.
  for (const std::string& bytes : {binary_ply(true, false, "uchar", "int"), binary_square_stl("x")}) {
    const std::string cut = dir.file(bytes.rfind("ply", 0) == 0 ? "p.ply" : "s.stl");
    for (std::size_t length = 0; length < bytes.size(); ++length) {
      write_text(cut, bytes.substr(0, length));
      expect_input_error(cut);
    }
  }
}

TEST(IoErrors, CorruptedBytesNeverCrash) {
  TempDir dir;
  const TriMesh m = make_sphere(1);
  std::mt19937 rng(5);
  for (const std::string name : {"c.obj", "c.off", "c.ply", "ca.ply"}) {
    write_mesh(dir.file(name), m, {}, name == "ca.ply");
    const std::string bytes = read_text(dir.file(name));
    for (int trial = 0; trial < 60; ++trial) {
      std::string damaged = bytes;
      for (int k = 0; k < 1 + trial % 4; ++k) damaged[rng() % damaged.size()] = static_cast<char>(rng());
      write_text(dir.file("d" + name), damaged);
      expect_no_crash(dir.file("d" + name));
    }
  }
  const std::string stl = binary_square_stl("x");
  for (int trial = 0; trial < 60; ++trial) {
    std::string damaged = stl;
    damaged[rng() % damaged.size()] = static_cast<char>(rng());
    write_text(dir.file("d.stl"), damaged);
    expect_no_crash(dir.file("d.stl"));
  }
}

// ---------------------------------------------------------------------------------------------
// Tet meshes

TetMesh small_tet_mesh() {
  TetMesh t;
  t.X.resize(5, 3);
  t.X << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1.0 / 3.0, 1.0 / 7.0, -2.5e-7;
  t.T.resize(2, 4);
  t.T << 0, 1, 2, 3, 1, 2, 3, 4;
  Eigen::MatrixXd thickness(5, 1), displacement(5, 3), stretch(2, 1), axis(2, 3);
  thickness << 0.1, 0.2, 0.3, 0.4, nan_value;
  displacement.setRandom();
  stretch << 1e-12, 3.5;
  axis.setRandom();
  t.point_data = {{"thickness", thickness}, {"displacement & <more>", displacement}};
  t.cell_data = {{"stretch", stretch}, {"axis \"quoted\"", axis}};
  return t;
}

TEST(IoTetMesh, VtuRoundTripKeepsPointsTetsAndNamedArrays) {
  TempDir dir;
  const TetMesh t = small_tet_mesh();
  write_tet_mesh(dir.file("shell.vtu"), t);
  const std::string text = read_text(dir.file("shell.vtu"));
  EXPECT_NE(text.find("type=\"UnstructuredGrid\""), std::string::npos);
  EXPECT_NE(text.find("Name=\"thickness\" NumberOfComponents=\"1\""), std::string::npos);
  EXPECT_NE(text.find("Name=\"axis &quot;quoted&quot;\" NumberOfComponents=\"3\""), std::string::npos);
  const TetMesh r = read_tet_mesh(dir.file("shell.vtu"));
  EXPECT_TRUE(r.X == t.X);
  EXPECT_TRUE(r.T == t.T);
  ASSERT_EQ(r.point_data.size(), 2u);
  ASSERT_EQ(r.cell_data.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(r.point_data[i].first, t.point_data[i].first);
    EXPECT_EQ(r.cell_data[i].first, t.cell_data[i].first);
    EXPECT_TRUE(r.point_data[i].second.cwiseEqual(t.point_data[i].second).count() +
                    r.point_data[i].second.array().isNaN().count() ==
                t.point_data[i].second.size());
    EXPECT_TRUE(r.cell_data[i].second == t.cell_data[i].second);
  }
  // The cell types are VTK_TETRA (10): the last K bytes of the appended data block.
  const std::size_t end = text.rfind("\n  </AppendedData>");
  EXPECT_EQ(text.substr(end - 2, 2), std::string("\x0a\x0a", 2));
}

TEST(IoTetMesh, VtuReaderTakesOtherByteOrderHeaderAndValueTypes) {
  // As another VTK writer may produce it: big endian, UInt32 block headers, Float32 points,
  // Int32 connectivity/offsets, a data array before the points, blocks in a different order.
  TempDir dir;
  Bytes data;
  const float points[4][3] = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {0, 0, 2.5f}};
  data.put<std::uint32_t>(4 * 4, true);
  for (std::int32_t id : {0, 1, 2, 3}) data.put<std::int32_t>(id, true);
  const std::size_t points_offset = data.s.size();
  data.put<std::uint32_t>(12 * 4, true);
  for (const auto& p : points)
    for (float v : p) data.put<float>(v, true);
  const std::size_t offsets_offset = data.s.size();
  data.put<std::uint32_t>(4, true).put<std::int32_t>(4, true);
  const std::size_t types_offset = data.s.size();
  data.put<std::uint32_t>(1, true).put<std::uint8_t>(10, true);
  const std::size_t scalar_offset = data.s.size();
  data.put<std::uint32_t>(4 * 4, true);
  for (float v : {1.f, 2.f, 3.f, 4.f}) data.put<float>(v, true);
  const std::string xml =
      "<?xml version=\"1.0\"?>\n<!-- hand made -->\n<VTKFile type='UnstructuredGrid' version=\"0.1\" "
      "byte_order=\"BigEndian\" header_type=\"UInt32\">\n<UnstructuredGrid>\n<Piece NumberOfPoints=\"4\" "
      "NumberOfCells=\"1\">\n<PointData Scalars=\"level\">\n<DataArray type=\"Float32\" Name=\"level\" "
      "format=\"appended\" offset=\"" + std::to_string(scalar_offset) +
      "\"/>\n</PointData>\n<CellData>\n</CellData>\n<Points>\n<DataArray type=\"Float32\" NumberOfComponents=\"3\" "
      "format=\"appended\" offset=\"" + std::to_string(points_offset) +
      "\"/>\n</Points>\n<Cells>\n<DataArray type=\"Int32\" Name=\"connectivity\" format=\"appended\" offset=\"0\"/>\n"
      "<DataArray type=\"Int32\" Name=\"offsets\" format=\"appended\" offset=\"" + std::to_string(offsets_offset) +
      "\"/>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"appended\" offset=\"" + std::to_string(types_offset) +
      "\"/>\n</Cells>\n</Piece>\n</UnstructuredGrid>\n<AppendedData encoding=\"raw\">\n_";
  write_text(dir.file("be.vtu"), xml + data.s + "\n</AppendedData>\n</VTKFile>\n");
  const TetMesh t = read_tet_mesh(dir.file("be.vtu"));
  ASSERT_EQ(t.X.rows(), 4);
  EXPECT_EQ(t.X(3, 2), 2.5);
  EXPECT_EQ(t.X(1, 0), 2.0);
  EXPECT_EQ(t.T.row(0), Eigen::RowVector4i(0, 1, 2, 3));
  ASSERT_EQ(t.point_data.size(), 1u);
  EXPECT_EQ(t.point_data[0].first, "level");
  EXPECT_EQ(t.point_data[0].second(3, 0), 4.0);
}

TEST(IoTetMesh, MeditRoundTripKeepsPointsAndTets) {
  TempDir dir;
  const TetMesh t = small_tet_mesh();
  write_tet_mesh(dir.file("shell.mesh"), t);
  const std::string text = read_text(dir.file("shell.mesh"));
  EXPECT_NE(text.find("Tetrahedra\n2\n1 2 3 4 1\n2 3 4 5 1\n"), std::string::npos) << "1-based ids";
  const TetMesh r = read_tet_mesh(dir.file("shell.mesh"));
  EXPECT_TRUE(r.X == t.X);
  EXPECT_TRUE(r.T == t.T);
  EXPECT_TRUE(r.point_data.empty() && r.cell_data.empty());
  // Other standard sections and comments are read past.
  write_text(dir.file("other.mesh"), "MeshVersionFormatted 1\n# c\nDimension\n3\nVertices\n4\n0 0 0 1\n1 0 0 1\n"
                                     "0 1 0 1\n0 0 1 1\nTriangles\n1\n1 2 3 0\nTetrahedra\n1\n1 2 3 4 0\nCorners\n1\n1\nEnd\n");
  const TetMesh o = read_tet_mesh(dir.file("other.mesh"));
  EXPECT_EQ(o.X.rows(), 4);
  EXPECT_EQ(o.T.row(0), Eigen::RowVector4i(0, 1, 2, 3));
}

TEST(IoTetMesh, MalformedTetFilesAreErrors) {
  TempDir dir;
  const TetMesh t = small_tet_mesh();
  write_tet_mesh(dir.file("ok.vtu"), t);
  write_tet_mesh(dir.file("ok.mesh"), t);
  auto expect_error = [&](const std::string& name, const std::string& content, const std::string& fragment) {
    const std::string path = dir.file(name);
    write_text(path, content);
    try {
      read_tet_mesh(path);
      ADD_FAILURE() << "no error for " << name;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos);
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  };
  const std::string vtu = read_text(dir.file("ok.vtu"));
  const std::string mesh = read_text(dir.file("ok.mesh"));
  const std::string marker = "encoding=\"raw\">\n   _";
  expect_error("a.vtu", vtu.substr(0, vtu.find(marker) + marker.size() + 40), "past the end");
  expect_error("b.vtu", vtu.substr(0, 200), "");
  std::string huge = vtu;
  huge.replace(huge.find("NumberOfPoints=\"5\""), 18, "NumberOfPoints=\"1000000000000000\"");
  expect_error("c.vtu", huge, "");
  expect_error("d.vtu", "garbage", "not a VTK XML file");
  expect_error("a.mesh", mesh.substr(0, mesh.find("Tetrahedra") + 15), "truncated");
  std::string bad_id = mesh;
  bad_id.replace(bad_id.find("2 3 4 5 1"), 9, "2 3 4 6 1");
  expect_error("b.mesh", bad_id, "refers to vertex 6");
  expect_error("c.mesh", "MeshVersionFormatted 2\nDimension 3\nVertices\n1000000000000\n0 0 0 0\n", "bytes");
  expect_error("d.mesh", "MeshVersionFormatted 2\nDimension 3\nBananas\n1\n", "Bananas");
  expect_error("e.tet", "", "unknown tet mesh format");
  expect_error("f.mesh", "", "no MeshVersionFormatted");
  // Every prefix of a .vtu: an error or (past the last array) a full mesh, never a crash.
  for (std::size_t length = 0; length < vtu.size(); length += 7) {
    write_text(dir.file("p.vtu"), vtu.substr(0, length));
    try {
      read_tet_mesh(dir.file("p.vtu"));
    } catch (const InputError&) {
    }
  }
}

TEST(IoTetMesh, FuzzFindingsInTetReadersAreErrors) {
  // Found by scripts/fuzz; each read used to be undefined behaviour or a mesh whose tets refer to
  // points that do not exist.
  TempDir dir;
  const std::string vtu = [&] {
    write_tet_mesh(dir.file("ok.vtu"), small_tet_mesh());
    return read_text(dir.file("ok.vtu"));
  }();
  // Where the first connectivity id of a file like write_tet_mesh's is (native byte order, after
  // the block's 8-byte header).
  auto first_id = [](const std::string& file) {
    const std::size_t data_start = file.find("encoding=\"raw\">") + std::string("encoding=\"raw\">\n   _").size();
    const std::size_t offset_at = file.find("offset=\"", file.find("Name=\"connectivity\"")) + 8;
    return data_start + std::stoul(file.substr(offset_at)) + 8;
  };
  auto expect_error = [&](const std::string& name, const std::string& content, const std::string& fragment) {
    write_text(dir.file(name), content);
    try {
      read_tet_mesh(dir.file(name));
      ADD_FAILURE() << "no error for " << name;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  };
  // vtu: an id beyond long long (converted from double for the message: UB).
  std::string huge_id = vtu;
  const std::int64_t big = 0x7ffffffffffffff6;
  std::memcpy(huge_id.data() + first_id(huge_id), &big, 8);
  expect_error("huge.vtu", huge_id, "cell 0 refers to point 9.2233720368547758e+18, not a point id (the file has 5 points)");
  // vtu: connectivity stored as floating point with a fraction (was truncated to point 1).
  std::string fraction = vtu;
  const std::size_t type_at = fraction.rfind("Int64", fraction.find("Name=\"connectivity\""));
  fraction.replace(type_at, 5, "Float64");
  const double one_and_a_half = 1.5;
  std::memcpy(fraction.data() + first_id(fraction), &one_and_a_half, 8);
  expect_error("fraction.vtu", fraction, "cell 0 refers to point 1.5, not a point id");
  // medit: a second Vertices section after the tets replaced the points they refer to.
  const std::string head = "MeshVersionFormatted 2\nDimension 3\nVertices\n4\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n"
                           "Tetrahedra\n1\n1 2 3 4 1\n";
  expect_error("twice.mesh", head + "Vertices\n1\n0 0 0 0\nEnd\n", "a second Vertices section (only one is supported) (line 12)");
  expect_error("tets_twice.mesh", head + "Tetrahedra\n1\n4 3 2 1 1\nEnd\n", "a second Tetrahedra section");
}

// ---------------------------------------------------------------------------------------------
// Atomic writes

TEST(IoAtomic, FailedWritesLeaveNothingAndKeepTheOldFile) {
  TempDir dir;
  const std::string path = dir.file("out.txt");
  write_file_atomically(path, [](std::ostream& out) { out << "first"; });
  EXPECT_EQ(read_text(path), "first");
  EXPECT_THROW(write_file_atomically(path,
                                     [](std::ostream& out) {
                                       out << "partial";
                                       throw std::runtime_error("boom");
                                     }),
               std::runtime_error);
  EXPECT_EQ(read_text(path), "first") << "old content must survive a failed write";
  EXPECT_EQ(gshell::test::count_entries(dir.path()), 1) << "temporary left behind";
  write_file_atomically(path, [](std::ostream& out) { out << "second"; });
  EXPECT_EQ(read_text(path), "second");
  EXPECT_EQ(gshell::test::count_entries(dir.path()), 1);

  EXPECT_THROW(write_file_atomically(dir.file("no/such/folder/x.txt"), [](std::ostream&) {}), InputError);
  EXPECT_THROW(write_file_atomically(dir.path().string(), [](std::ostream&) {}), InputError);
  const TriMesh m = make_sphere(0);
  EXPECT_THROW(write_mesh(dir.file("m.stl"), m), InputError);
  EXPECT_THROW(write_mesh(dir.file("m.abc"), m), InputError);
  EXPECT_THROW(write_tet_mesh(dir.file("m.vtk"), small_tet_mesh()), InputError);
  EXPECT_EQ(gshell::test::count_entries(dir.path()), 1);
}

// An output named by a symbolic link is written where the link leads, and the link stays (the
// rename replaced the link with a file, leaving its target unchanged).
TEST(IoAtomic, AnOutputThroughASymbolicLinkReachesItsTargetAndKeepsTheLink) {
  TempDir dir;
  const std::string target = dir.file("target.txt"), link = dir.file("link.txt");
  write_file_atomically(target, [](std::ostream& out) { out << "old"; });
  std::filesystem::create_symlink("target.txt", link);
  write_file_atomically(link, [](std::ostream& out) { out << "new"; });
  EXPECT_TRUE(std::filesystem::is_symlink(link));
  EXPECT_EQ(read_text(target), "new");
  EXPECT_EQ(gshell::test::count_entries(dir.path()), 2);
  // A dangling link: the file is made where it points.
  std::filesystem::create_symlink("later.txt", dir.file("dangling.txt"));
  write_file_atomically(dir.file("dangling.txt"), [](std::ostream& out) { out << "made"; });
  EXPECT_TRUE(std::filesystem::is_symlink(dir.file("dangling.txt")));
  EXPECT_EQ(read_text(dir.file("later.txt")), "made");
}

// A run killed outright (kill -9) leaves its temporary beside the output; the next write of that
// output removes it, but not a live process's, another output's, or a name that is not one.
TEST(IoAtomic, TemporariesOfKilledRunsAreRemovedByTheNextRunWritingThatOutput) {
  TempDir dir;
  const pid_t gone = fork();
  if (gone == 0) _exit(0);
  ASSERT_GT(gone, 0);
  waitpid(gone, nullptr, 0); // reaped: its id names no process now (unless reused at once)
  const std::string dead = std::to_string(gone), alive = std::to_string(getpid());
  for (const std::string& name : {".out.obj.tmp-" + dead + "-5-0", ".out.obj.tmp-" + alive + "-5-1",
                                  ".other.obj.tmp-" + dead + "-5-2", ".out.obj.tmpx-" + dead + "-5-3"})
    write_text(dir.file(name), "partial");
  ASSERT_EQ(gshell::test::run_cli("-q convert builtin:sphere:0 '" + dir.file("out.obj") + "'").exit_code, 0);
  std::vector<std::string> left;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) left.push_back(entry.path().filename());
  std::sort(left.begin(), left.end());
  EXPECT_EQ(left, (std::vector<std::string>{".other.obj.tmp-" + dead + "-5-2", ".out.obj.tmp-" + alive + "-5-1",
                                            ".out.obj.tmpx-" + dead + "-5-3", "out.obj"}));
}

} // namespace
