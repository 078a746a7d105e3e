// Wavefront OBJ: v (x y z [w | r g b]), vt (u [v [w]]), f with corners i, i/t, i//n, i/t/n, and
// negative (relative) indices; polygons are fan-triangulated; a line ending in a backslash
// continues on the next. Normals, groups, materials and
// free-form statements are read past. Texture coordinates are kept when every face has them;
// when only some faces do, they are dropped (a partial UV layout cannot drive a texture).
// Positive indices may refer to vertices defined later in the file (the format allows it), so
// they are range-checked at the end, with the line of the offending face.
#include "surface_readers.h"
#include "text_scanner.h"

#include <gshell/error.h>

#include <algorithm>
#include <array>
#include <string>
#include <unordered_set>

namespace gshell::io_detail {

namespace {

// Statements of the OBJ specification that carry nothing gshell uses.
bool is_ignored_statement(std::string_view key) {
  static const std::unordered_set<std::string_view> ignored = {
      "vn", "vp", "l", "p", "g", "o", "s", "mg", "usemtl", "mtllib", "cstype", "deg", "bmat", "step",
      "curv", "curv2", "surf", "parm", "trim", "hole", "scrv", "sp", "end", "con", "bevel", "c_interp",
      "d_interp", "lod", "shadow_obj", "trace_obj", "ctech", "stech", "maplib", "usemap", "call", "csh"};
  return ignored.count(key) > 0;
}

struct Corner {
  long long vertex = 0;
  long long texture = 0; ///< 0 = none
};

// Resolves an OBJ index (1-based, or negative = counted back from the last one read so far)
// to 0-based. Positive ones are checked later, once all vertices are known.
long long resolve(long long index, long long count_so_far, const TextScanner& s, const char* what) {
  if (index == 0) s.fail(std::string(what) + " index 0 (OBJ indices start at 1)");
  if (index > 0) return index - 1;
  const long long resolved = count_so_far + index;
  if (resolved < 0)
    s.fail(std::string("relative ") + what + " index " + std::to_string(index) + " points before the first one");
  return resolved;
}

Corner parse_corner(std::string_view token, long long num_v, long long num_vt, const TextScanner& s) {
  Corner c;
  const std::size_t slash1 = token.find('/');
  c.vertex = resolve(s.to_integer(token.substr(0, slash1), "a vertex index"), num_v, s, "vertex");
  if (slash1 == std::string_view::npos) {
    c.texture = -1;
    return c;
  }
  const std::string_view rest = token.substr(slash1 + 1);
  const std::size_t slash2 = rest.find('/');
  const std::string_view texture = rest.substr(0, slash2);
  if (slash2 != std::string_view::npos) {
    const std::string_view normal = rest.substr(slash2 + 1);
    if (!normal.empty()) s.to_integer(normal, "a normal index");
  }
  c.texture = texture.empty() ? -1 : resolve(s.to_integer(texture, "a texture index"), num_vt, s, "texture");
  return c;
}

} // namespace

TriMesh read_obj(const std::string& path, std::string_view bytes, std::vector<std::string>* warnings,
                 std::vector<std::string>* skipped_names) {
  SkippedData skipped(skipped_names);
  // Each kind named once, when first met (not looked up again at every line that has it).
  bool vertex_colors = false, normals = false, materials = false;
  auto note = [&](bool& seen, const char* name) {
    if (!seen) skipped.add(name);
    seen = true;
  };
  TextScanner s(bytes, path, '#');
  s.allow_line_continuation();
  SurfaceBuilder b;
  std::vector<int> triangle_lines; // line of each triangle, for late index checks
  std::vector<long long> vertex_ids, texture_ids;
  std::vector<int> polygon, polygon_uv;
  bool all_faces_textured = true;
  long long polygons = 0, textured_polygons = 0;
  bool any_statement = false;

  while (!s.at_end()) {
    const std::string_view key = s.next_token();
    any_statement = true;
    if (key == "v") {
      std::array<double, 3> p{};
      for (double& x : p) {
        const std::string_view t = s.next_token_on_line();
        if (t.empty()) s.fail("vertex with fewer than 3 coordinates");
        x = s.to_double(t, "a vertex coordinate");
      }
      int extra = 0; // one: a weight (rational curves); three or more: a color (a common extension)
      for (std::string_view t = s.next_token_on_line(); !t.empty(); t = s.next_token_on_line(), ++extra)
        s.to_double(t, "a vertex weight or color");
      if (extra >= 3) note(vertex_colors, "vertex colors");
      if (b.num_vertices() >= max_element_count) s.fail("too many vertices");
      b.xyz.insert(b.xyz.end(), p.begin(), p.end());
    } else if (key == "vt") {
      const std::string_view tu = s.next_token_on_line();
      if (tu.empty()) s.fail("texture coordinate without values");
      const double u = s.to_double(tu, "a texture coordinate");
      const std::string_view tv = s.next_token_on_line();
      const double v = tv.empty() ? 0.0 : s.to_double(tv, "a texture coordinate");
      for (std::string_view t = s.next_token_on_line(); !t.empty(); t = s.next_token_on_line())
        s.to_double(t, "a texture coordinate");
      b.uv.push_back(u);
      b.uv.push_back(v);
    } else if (key == "f") {
      polygon.clear();
      polygon_uv.clear();
      int textured = 0, corners = 0;
      for (std::string_view t = s.next_token_on_line(); !t.empty(); t = s.next_token_on_line()) {
        const Corner c = parse_corner(t, b.num_vertices(), static_cast<long long>(b.uv.size() / 2), s);
        if (c.vertex >= max_element_count || c.texture >= max_element_count) s.fail("index too large");
        polygon.push_back(static_cast<int>(c.vertex));
        polygon_uv.push_back(static_cast<int>(c.texture));
        textured += c.texture >= 0;
        ++corners;
      }
      if (corners < 3) s.fail("face with " + std::to_string(corners) + " corners, need at least 3");
      if (textured != 0 && textured != corners)
        s.fail("face mixes corners with and without texture coordinates");
      if (textured == 0) all_faces_textured = false;
      ++polygons;
      textured_polygons += textured != 0;
      const std::size_t before = b.corners.size();
      SurfaceBuilder::add_fan(b.corners, polygon);
      if (all_faces_textured) SurfaceBuilder::add_fan(b.uv_corners, polygon_uv);
      triangle_lines.insert(triangle_lines.end(), (b.corners.size() - before) / 3, s.line());
      if (b.corners.size() / 3 >= static_cast<std::size_t>(max_element_count)) s.fail("too many faces");
    } else if (is_ignored_statement(key)) {
      if (key == "vn") note(normals, "normals");
      else if (key == "usemtl" || key == "mtllib") note(materials, "materials");
      s.skip_rest_of_line();
    } else {
      s.fail("unknown OBJ statement '" + std::string(key.substr(0, 40)) + "' (not an OBJ file?)");
    }
  }
  if (!any_statement) s.fail_without_line("empty file, no vertices or faces");

  const long long n = b.num_vertices();
  for (std::size_t i = 0; i < b.corners.size(); ++i)
    if (b.corners[i] >= n)
      s.fail_without_line("face refers to vertex " + std::to_string(b.corners[i] + 1) + " but the file has only " +
                          std::to_string(n) + " vertices (line " + std::to_string(triangle_lines[i / 3]) + ")");
  if (!all_faces_textured || b.corners.empty()) {
    if (warnings && textured_polygons > 0)
      warnings->push_back(with_file(path, std::to_string(polygons - textured_polygons) + " of " +
                                              std::to_string(polygons) +
                                              " faces have no texture coordinates: all are dropped (a texture "
                                              "needs every face in the UV layout)"));
    b.uv.clear();
    b.uv_corners.clear();
  } else {
    const long long k = static_cast<long long>(b.uv.size() / 2);
    for (std::size_t i = 0; i < b.uv_corners.size(); ++i)
      if (b.uv_corners[i] >= k)
        s.fail_without_line("face refers to texture coordinate " + std::to_string(b.uv_corners[i] + 1) +
                            " but the file has only " + std::to_string(k) + " (line " +
                            std::to_string(triangle_lines[i / 3]) + ")");
  }
  return b.finish();
}

} // namespace gshell::io_detail
