// OFF with the optional prefixes of the format ([ST][C][N]OFF: texture coordinates, colors,
// normals per vertex), '#' comments, and a missing keyword (plain counts first). One vertex per
// line (x y z, then whatever the prefixes add, which is checked to be numeric and ignored); faces
// "n i_1 .. i_n [color]", fan-triangulated. 4D/nD and binary OFF are refused with a message.
// The header's counts are checked against the bytes present before anything is reserved, and
// data left after the last face means the counts are wrong: both are errors.
#include "surface_readers.h"
#include "text_scanner.h"

#include <string>

namespace gshell::io_detail {

namespace {

// Smallest text a vertex ("0 0 0\n") and a triangle ("3 0 1 2\n") can take.
constexpr long long min_vertex_bytes = 6;
constexpr long long min_face_bytes = 8;

bool is_off_keyword(std::string_view key) {
  if (key.size() < 3 || key.substr(key.size() - 3) != "OFF") return false;
  std::string_view prefix = key.substr(0, key.size() - 3);
  if (prefix.starts_with("ST")) prefix.remove_prefix(2);
  if (prefix.starts_with("C")) prefix.remove_prefix(1);
  if (prefix.starts_with("N")) prefix.remove_prefix(1);
  if (prefix.starts_with("4")) prefix.remove_prefix(1);
  if (prefix.starts_with("n")) prefix.remove_prefix(1);
  return prefix.empty();
}

} // namespace

TriMesh read_off(const std::string& path, std::string_view bytes, std::vector<std::string>* skipped_names) {
  TextScanner s(bytes, path, '#');
  std::string_view token = s.next_token();
  if (token.empty()) s.fail_without_line("empty file, expected an OFF header");
  // What the values after a vertex's coordinates are, by the header's prefix ([ST][C][N]OFF).
  std::vector<std::string> vertex_extras{"vertex colors"};
  if (is_off_keyword(token)) {
    const std::string_view key = token;
    std::vector<std::string> kinds;
    if (key.find("N") != std::string_view::npos) kinds.push_back("normals");
    if (key.find("C") != std::string_view::npos) kinds.push_back("vertex colors");
    if (key.find("ST") != std::string_view::npos) kinds.push_back("texture coordinates");
    if (!kinds.empty()) vertex_extras = std::move(kinds);
    if (key.find('4') != std::string_view::npos || key.find('n') != std::string_view::npos)
      s.fail("'" + std::string(key) + "' (4D/nD OFF) is not supported, only 3D surfaces");
    token = s.next_token();
    if (token == "BINARY") s.fail("binary OFF is not supported, convert it to ASCII OFF or PLY");
  } else {
    long long ignored = 0;
    if (!parse_integer(token, ignored))
      s.fail("expected the keyword OFF (or COFF, NOFF, ...) at the start, found '" +
             std::string(token.substr(0, 40)) + "' (not an OFF file?)");
  }
  if (token.empty()) s.fail("unexpected end of file, expected the vertex count");
  const long long nv = s.to_integer(token, "the vertex count");
  const long long nf = s.next_integer("the face count");
  if (!s.at_line_end()) s.next_integer("the edge count");
  if (nv < 0 || nf < 0) s.fail("negative vertex or face count");
  if (nv > max_element_count || nf > max_element_count) s.fail("vertex or face count too large");
  const long long remaining = static_cast<long long>(bytes.size() - s.position());
  if (nv * min_vertex_bytes + nf * min_face_bytes > remaining + 1)
    s.fail("header claims " + std::to_string(nv) + " vertices and " + std::to_string(nf) +
           " faces but only " + std::to_string(remaining) + " bytes follow (truncated or wrong counts)");
  s.skip_rest_of_line();

  SurfaceBuilder b;
  bool vertex_values = false, face_values = false; // beyond the coordinates and the indices
  b.xyz.reserve(static_cast<std::size_t>(3 * nv));
  b.corners.reserve(static_cast<std::size_t>(3 * nf));
  for (long long i = 0; i < nv; ++i) {
    const std::string_view first = s.next_token();
    if (first.empty())
      s.fail("unexpected end of file after " + std::to_string(i) + " of " + std::to_string(nv) +
             " vertices (truncated or wrong counts)");
    b.xyz.push_back(s.to_double(first, "a vertex coordinate"));
    for (int k = 0; k < 2; ++k) {
      const std::string_view t = s.next_token_on_line();
      if (t.empty()) s.fail("vertex " + std::to_string(i) + " has fewer than 3 coordinates");
      b.xyz.push_back(s.to_double(t, "a vertex coordinate"));
    }
    for (std::string_view t = s.next_token_on_line(); !t.empty(); t = s.next_token_on_line()) {
      s.to_double(t, "a vertex normal, color or texture value");
      vertex_values = true;
    }
  }
  std::vector<int> polygon;
  for (long long f = 0; f < nf; ++f) {
    const std::string_view first = s.next_token();
    if (first.empty())
      s.fail("unexpected end of file after " + std::to_string(f) + " of " + std::to_string(nf) +
             " faces (truncated or wrong counts)");
    const long long count = s.to_integer(first, "the number of vertices of a face");
    if (count < 3) s.fail("face " + std::to_string(f) + " has " + std::to_string(count) + " vertices, need at least 3");
    polygon.clear();
    for (long long k = 0; k < count; ++k) {
      const std::string_view t = s.next_token_on_line();
      if (t.empty())
        s.fail("face " + std::to_string(f) + " lists fewer vertices than its count " + std::to_string(count));
      const long long id = s.to_integer(t, "a vertex index");
      if (id < 0 || id >= nv)
        s.fail("face " + std::to_string(f) + " refers to vertex " + std::to_string(id) + " but there are " +
               std::to_string(nv) + " vertices");
      polygon.push_back(static_cast<int>(id));
    }
    for (std::string_view t = s.next_token_on_line(); !t.empty(); t = s.next_token_on_line()) {
      s.to_double(t, "a face color value");
      face_values = true;
    }
    SurfaceBuilder::add_fan(b.corners, polygon);
    if (b.corners.size() / 3 >= static_cast<std::size_t>(max_element_count)) s.fail("too many faces");
  }
  if (!s.at_end()) {
    s.next_token();
    s.fail("unexpected data after the " + std::to_string(nf) + " faces the header announced (wrong counts?)");
  }
  SkippedData skipped(skipped_names);
  if (vertex_values)
    for (const std::string& name : vertex_extras) skipped.add(name);
  if (face_values) skipped.add("face colors");
  return b.finish();
}

} // namespace gshell::io_detail
