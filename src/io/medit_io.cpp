// MEDIT .mesh (ASCII): Vertices "x y z ref" and Tetrahedra "a b c d ref", 1-based ids. The writer
// puts reference 0 on vertices and 1 on tets (data arrays have no place in the format). The reader
// takes Vertices and Tetrahedra and reads past the other standard sections (triangles, edges,
// corners, ...), checking each count against the bytes left before reserving.
#include "tet_formats.h"
#include "text_out.h"
#include "text_scanner.h"

#include <cctype>
#include <string>

namespace gshell::io_detail {

void write_medit(std::ostream& out, const TetMesh& m) {
  TextOut o(out);
  o << "MeshVersionFormatted 2\nDimension 3\n\nVertices\n" << static_cast<long long>(m.X.rows()) << '\n';
  for (Eigen::Index i = 0; i < m.X.rows(); ++i) o << m.X(i, 0) << ' ' << m.X(i, 1) << ' ' << m.X(i, 2) << " 0\n";
  o << "\nTetrahedra\n" << static_cast<long long>(m.T.rows()) << '\n';
  for (Eigen::Index t = 0; t < m.T.rows(); ++t)
    o << m.T(t, 0) + 1 << ' ' << m.T(t, 1) + 1 << ' ' << m.T(t, 2) + 1 << ' ' << m.T(t, 3) + 1 << " 1\n";
  o << "\nEnd\n";
}

namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

// Numbers per item of the sections we read past.
int values_per_item(const std::string& section) {
  if (section == "edges") return 3;
  if (section == "triangles") return 4;
  if (section == "quadrilaterals") return 5;
  if (section == "prisms") return 7;
  if (section == "hexahedra") return 9;
  if (section == "corners" || section == "ridges" || section == "requiredvertices" || section == "requirededges" ||
      section == "requiredtriangles")
    return 1;
  if (section == "normals" || section == "tangents") return 3;
  if (section == "normalatvertices" || section == "tangentatvertices") return 2;
  return 0;
}

} // namespace

TetMesh read_medit(const std::string& path, std::string_view bytes) {
  TextScanner s(bytes, path, '#');
  TetMesh mesh;
  mesh.X.resize(0, 3);
  mesh.T.resize(0, 4);
  bool have_vertices = false, have_tets = false, have_version = false;
  auto read_count = [&](const std::string& section, int values) {
    const long long n = s.next_integer("a section count");
    if (n < 0) s.fail("negative " + section + " count");
    const long long remaining = static_cast<long long>(bytes.size() - s.position());
    if (n > remaining || n * values * 2 > remaining + 1)
      s.fail(section + " claims " + std::to_string(n) + " items but only " + std::to_string(remaining) +
             " bytes follow (truncated or wrong counts)");
    return n;
  };
  while (true) {
    const std::string_view token = s.next_token();
    if (token.empty()) break; // "End" is optional in practice
    const std::string key = lower(token);
    if (key == "end") {
      if (!s.at_end()) {
        s.next_token();
        s.fail("data after 'End'");
      }
      break;
    }
    if (key == "meshversionformatted") {
      const long long v = s.next_integer("the mesh version");
      if (v < 1 || v > 3) s.fail("unsupported MeshVersionFormatted " + std::to_string(v));
      have_version = true;
    } else if (key == "dimension") {
      const long long d = s.next_integer("the dimension");
      if (d != 3) s.fail("dimension " + std::to_string(d) + ", only 3D meshes are supported");
    } else if (key == "vertices") {
      // A second section would replace the points the tets already refer to.
      if (have_vertices) s.fail("a second Vertices section (only one is supported)");
      const long long n = read_count("Vertices", 4);
      mesh.X.resize(n, 3);
      for (long long i = 0; i < n; ++i) {
        for (int c = 0; c < 3; ++c) mesh.X(i, c) = s.next_double("a vertex coordinate");
        s.next_integer("a vertex reference");
      }
      have_vertices = true;
    } else if (key == "tetrahedra") {
      if (!have_vertices) s.fail("Tetrahedra before Vertices");
      if (have_tets) s.fail("a second Tetrahedra section (only one is supported)");
      have_tets = true;
      const long long n = read_count("Tetrahedra", 5);
      mesh.T.resize(n, 4);
      for (long long t = 0; t < n; ++t) {
        for (int c = 0; c < 4; ++c) {
          const long long id = s.next_integer("a tetrahedron vertex id");
          if (id < 1 || id > mesh.X.rows())
            s.fail("tetrahedron " + std::to_string(t + 1) + " refers to vertex " + std::to_string(id) + " of " +
                   std::to_string(mesh.X.rows()));
          mesh.T(t, c) = static_cast<int>(id - 1);
        }
        s.next_integer("a tetrahedron reference");
      }
    } else if (const int values = values_per_item(key); values > 0) {
      const long long n = read_count(std::string(token), values);
      for (long long i = 0; i < n * values; ++i) s.next_double("a value");
    } else {
      s.fail("unknown MEDIT keyword '" + std::string(token.substr(0, 40)) + "'");
    }
  }
  if (!have_version) s.fail_without_line("not a MEDIT mesh (no MeshVersionFormatted)");
  if (!have_vertices) s.fail_without_line("MEDIT mesh has no Vertices");
  return mesh;
}

} // namespace gshell::io_detail
