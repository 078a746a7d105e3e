// PLY writer: binary little endian (default) or ASCII. Positions and scalar properties are
// double, so values round-trip exactly; colors are uchar red/green/blue; faces are
// "list uchar int vertex_indices". Scalar names must be single words that do not clash with
// the standard properties.
#include "binary_codec.h"
#include "surface_writers.h"
#include "text_out.h"

#include <gshell/error.h>

#include <cstdint>
#include <set>
#include <string>

namespace gshell::io_detail {

namespace {

void check_scalar_names(const std::vector<std::pair<std::string, Eigen::VectorXd>>& scalars,
                        std::set<std::string> taken) {
  for (const auto& [name, values] : scalars) {
    bool ok = !name.empty();
    for (char c : name) ok = ok && (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.');
    if (!ok) throw InputError("write_mesh: PLY property name '" + name + "' must be one word of [A-Za-z0-9_.-]");
    if (!taken.insert(name).second) throw InputError("write_mesh: PLY property name '" + name + "' is used twice");
  }
}

std::string ply_header(const TriMesh& mesh, const MeshAttributes& a, bool ascii) {
  std::string h = "ply\nformat ";
  h += ascii ? "ascii 1.0\n" : "binary_little_endian 1.0\n";
  h += "comment gshell\n";
  h += "element vertex " + std::to_string(mesh.num_vertices()) + "\n";
  h += "property double x\nproperty double y\nproperty double z\n";
  if (a.vertex_colors.rows() > 0) h += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  for (const auto& s : a.vertex_scalars) h += "property double " + s.first + "\n";
  h += "element face " + std::to_string(mesh.num_faces()) + "\n";
  h += "property list uchar int vertex_indices\n";
  if (a.face_colors.rows() > 0) h += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  for (const auto& s : a.face_scalars) h += "property double " + s.first + "\n";
  h += "end_header\n";
  return h;
}

void write_binary_body(std::ostream& out, const TriMesh& mesh, const MeshAttributes& a) {
  std::string buffer;
  auto drain = [&](bool force) {
    if (force || buffer.size() > (1u << 20)) {
      out.write(buffer.data(), static_cast<std::streamsize>(buffer.size()));
      buffer.clear();
    }
  };
  const bool vc = a.vertex_colors.rows() > 0, fc = a.face_colors.rows() > 0;
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) {
    for (int k = 0; k < 3; ++k) append_little_endian<double>(buffer, mesh.V(i, k));
    if (vc)
      for (int k = 0; k < 3; ++k) buffer.push_back(static_cast<char>(a.vertex_colors(i, k)));
    for (const auto& s : a.vertex_scalars) append_little_endian<double>(buffer, s.second[i]);
    drain(false);
  }
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    buffer.push_back(3);
    for (int k = 0; k < 3; ++k) append_little_endian<std::int32_t>(buffer, mesh.F(f, k));
    if (fc)
      for (int k = 0; k < 3; ++k) buffer.push_back(static_cast<char>(a.face_colors(f, k)));
    for (const auto& s : a.face_scalars) append_little_endian<double>(buffer, s.second[f]);
    drain(false);
  }
  drain(true);
}

void write_ascii_body(std::ostream& out, const TriMesh& mesh, const MeshAttributes& a) {
  TextOut o(out);
  const bool vc = a.vertex_colors.rows() > 0, fc = a.face_colors.rows() > 0;
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) {
    o << mesh.V(i, 0) << ' ' << mesh.V(i, 1) << ' ' << mesh.V(i, 2);
    if (vc)
      for (int k = 0; k < 3; ++k) o << ' ' << int(a.vertex_colors(i, k));
    for (const auto& s : a.vertex_scalars) o << ' ' << s.second[i];
    o << '\n';
  }
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    o << "3 " << mesh.F(f, 0) << ' ' << mesh.F(f, 1) << ' ' << mesh.F(f, 2);
    if (fc)
      for (int k = 0; k < 3; ++k) o << ' ' << int(a.face_colors(f, k));
    for (const auto& s : a.face_scalars) o << ' ' << s.second[f];
    o << '\n';
  }
}

} // namespace

void write_ply(std::ostream& out, const TriMesh& mesh, const MeshAttributes& a, bool ascii) {
  std::set<std::string> vertex_taken{"x", "y", "z"}, face_taken{"vertex_indices"};
  if (a.vertex_colors.rows() > 0) vertex_taken.insert({"red", "green", "blue"});
  if (a.face_colors.rows() > 0) face_taken.insert({"red", "green", "blue"});
  check_scalar_names(a.vertex_scalars, vertex_taken);
  check_scalar_names(a.face_scalars, face_taken);
  const std::string header = ply_header(mesh, a, ascii);
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
  if (ascii) write_ascii_body(out, mesh, a);
  else write_binary_body(out, mesh, a);
}

} // namespace gshell::io_detail
